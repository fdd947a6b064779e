"""The ``choreo`` command: the only place that prints or configures logging.

Each command group lives in its own module with ``register(subparsers)``; a command's handler
takes the parsed args and returns an exit code. Exit codes: 0 ok, 1 a ``ChoreoError`` (one clear
line, no traceback), 2 usage (argparse's own, or a ``UsageError`` raised by a handler), 130 after
Ctrl-C (or SIGTERM/SIGHUP where a command turns them into Ctrl-C). Errors are turned into exit
codes here and nowhere else.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence

from choreo import __version__
from choreo.cli import (
    bus_commands,
    emulate_commands,
    interop_commands,
    motion_commands,
    music_commands,
    plan_commands,
    play_commands,
    ports_commands,
    preview_commands,
    record_commands,
    robot_commands,
    servo_commands,
    show_commands,
    studio_commands,
)
from choreo.errors import ChoreoError, OptionError, UsageError

COMMAND_GROUPS = (
    bus_commands,
    ports_commands,
    emulate_commands,
    robot_commands,
    motion_commands,
    plan_commands,
    music_commands,
    play_commands,
    preview_commands,
    servo_commands,
    record_commands,
    interop_commands,
    show_commands,
    studio_commands,
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="choreo",
        description="Author, plan, preview and play motions on Hiwonder/LewanSoul bus servos.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for group in COMMAND_GROUPS:
        group.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.WARNING - 10 * min(args.verbose, 2),
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        code = args.handler(args)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's final flush
        return code
    except UsageError as error:
        print(f"choreo: error: {error}", file=sys.stderr)
        return 2
    except OptionError as error:  # a library argument: named as this command's flag
        print(f"choreo: error: {flag_of(error.option)} {error.problem}", file=sys.stderr)
        return 2
    except ChoreoError as error:
        print(f"choreo: error: {error}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # `choreo ... | head`: the reader has all it wanted. Quietly, and exit 1 as the Python
        # docs' note on SIGPIPE and rich's consoles do: the output was cut short.
        _silence_stdout()
        return 1
    except OSError as error:  # a file that can't be written, a port that went away
        print(f"choreo: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("choreo: interrupted", file=sys.stderr)
        return 130


def flag_of(option: str) -> str:
    """The command-line flag of a library argument: ``exit_pose`` is ``--exit-pose``."""
    return "--" + option.replace("_", "-")


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush doesn't fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
