"""The ``choreo`` command: the only place that prints or configures logging.

Each command group lives in its own module with ``register(subparsers)``; a command's handler
takes the parsed args and returns an exit code. Exit codes: 0 ok, 1 a ``ChoreoError`` (one clear
line, no traceback), 2 usage, 130 after Ctrl-C.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from ..errors import ChoreoError
from . import (
    bus_commands,
    emulate_command,
    interop_commands,
    motion_commands,
    music_commands,
    plan_commands,
    play_command,
    preview_command,
    record_command,
    servo_commands,
)

COMMAND_GROUPS = (
    bus_commands,
    emulate_command,
    motion_commands,
    plan_commands,
    music_commands,
    play_command,
    preview_command,
    servo_commands,
    record_command,
    interop_commands,
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="choreo",
        description="Author, plan, preview and play motions on Hiwonder/LewanSoul bus servos.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
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
        return args.handler(args)
    except ChoreoError as error:
        print(f"choreo: error: {error}", file=sys.stderr)
        return 1
    except OSError as error:  # a file that can't be written, a port that went away
        print(f"choreo: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("choreo: interrupted", file=sys.stderr)
        return 130
