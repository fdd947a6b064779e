"""The ``choreo`` command line: the parser, ``main`` and the turning of errors into exit codes.

Each command group lives in its own module with ``register(subparsers)``; a command's handler
takes the parsed args and returns an exit code. Exit codes: 0 ok, 1 a ``ChoreoError`` (one clear
line, no traceback), 2 usage (argparse's own, or a ``UsageError`` raised by a handler), 130 after
Ctrl-C (or SIGTERM/SIGHUP while the command's modules load, or where a command turns them into
Ctrl-C), 70 for a bug (any other exception: one line saying so, the traceback in a file, or on
stderr with -v). Errors are turned into exit codes here and nowhere else.
"""

from __future__ import annotations

import argparse
import errno
import gc
import importlib
import io
import logging
import os
import signal
import sys
import traceback
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType

from choreo import __version__
from choreo.cli import interrupted
from choreo.core.collector import collector_paused
from choreo.core.file_kind import os_error_text
from choreo.errors import BusError, ChoreoError, OptionError, UsageError, worded

# Which module registers (and runs) each command. Only the module of the command being run is
# imported, so that `choreo scan --help` does not pay for planning, MuJoCo or music; the whole
# table is loaded for `choreo --help` or a command that is not in it (argparse then lists them).
# tests/test_package.py checks that each module registers exactly the commands given here.
COMMAND_MODULES = {
    "scan": "bus_commands",
    "ports": "ports_commands",
    "emulate": "emulate_commands",
    "robots": "robot_commands",
    "validate": "motion_commands",
    "plan": "plan_commands",
    "beats": "music_commands",
    "play": "play_commands",
    "preview": "preview_commands",
    "servo": "servo_commands",
    "record": "record_commands",
    "import": "interop_commands",
    "export": "interop_commands",
    "mirror": "interop_commands",
    "perform": "show_commands",
    "show": "show_commands",
    "studio": "studio_commands",
    "identify": "identify_commands",
}


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or only of the one ``argv`` runs when it names one."""
    parser = argparse.ArgumentParser(
        prog="choreo",
        description="Author, plan, preview and play motions on Hiwonder/LewanSoul bus servos.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=CommandParser
    )
    for group in command_groups(argv):
        group.register(subparsers)
    return parser


class CommandParser(argparse.ArgumentParser):
    """A command's parser (a subcommand's too: argparse makes them of their parent's class).
    It refuses the arguments it does not know itself, with its own usage; argparse would leave
    them to the top parser, which prints the usage of ``choreo``, not of the command."""

    def parse_known_args(self, args=None, namespace=None):
        parsed, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed, extras


def command_groups(argv: Sequence[str] | None) -> list[ModuleType]:
    """The command modules to register: the one of ``argv``'s command; all of them for the
    help that lists them (``choreo --help``, an unknown command); none for ``--version``. The
    global options take no value, so the command is the first word that is not an option."""
    words = list(argv) if argv is not None else None
    command = next((word for word in words or () if not word.startswith("-")), None)
    if command in COMMAND_MODULES:
        names = [COMMAND_MODULES[command]]
    elif command is None and words is not None and "--version" in words:
        names = []
    else:
        names = list(COMMAND_MODULES.values())
    return [importlib.import_module(f"choreo.cli.{name}") for name in dict.fromkeys(names)]


def main(argv: Sequence[str] | None = None) -> int:
    for stream in (sys.stdout, sys.stderr):
        # a terminal or pipe that cannot encode "°" or a file's name shows it escaped (\xb0):
        # output never fails on its encoding
        if isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(errors="backslashreplace")
    if argv is None:
        argv = sys.argv[1:]
    put_aside_mujoco_gl()
    one_blas_thread()
    unblock_stop_signals()
    try:
        # the command's modules load here (a second for play): Ctrl-C, SIGTERM or SIGHUP
        # meanwhile end the command as they do once it runs, once the modules are loaded
        # (interrupted inside a compiled module's initialisation, Python would end by the
        # signal, not with 130)
        from choreo.cli.arguments import ctrl_c_deferred, handler_modules

        with ctrl_c_deferred(), collector_paused():
            args = build_parser(argv).parse_args(argv)
            for module in handler_modules(args.handler):  # what it imports where it runs
                importlib.import_module(module)
            # The modules' functions, classes and tables (some 100,000 objects, no garbage)
            # stay to the end: the collector was paused while they loaded, and passes over
            # them until the command is done (0.02 s of a `choreo plan`)
            gc.freeze()
    except KeyboardInterrupt:
        return interrupted()
    logging.basicConfig(
        level=logging.WARNING - 10 * min(args.verbose, 2),
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        with python_warnings_for_developers(args.verbose):
            code = args.handler(args)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's final flush
        return code
    except UsageError as error:
        print(f"choreo: error: {error}", file=sys.stderr)
        return 2
    except OptionError as error:  # a library argument: named as this command's flag
        print(f"choreo: error: {error.worded(flag_of)}", file=sys.stderr)
        return 2
    except ChoreoError as error:
        print(f"choreo: error: {error.worded(flag_of)}", file=sys.stderr)
        hint = hint_for(error)
        if hint:
            print(f"choreo: hint: {hint}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # `choreo ... | head`: the reader has all it wanted. Quietly, and exit 1 as the Python
        # docs' note on SIGPIPE and rich's consoles do: the output was cut short.
        _silence_stdout()
        return 1
    except KeyboardInterrupt:
        return interrupted()
    except OSError as error:
        if error.errno in (None, errno.EBADF):  # not the OS refusing: choreo misused a file
            return report_bug(error, args.verbose)
        # a file that can't be read or written, a full disk, a device that went away
        print(f"choreo: error: {os_error_text(error)}", file=sys.stderr)
        return 1
    except Exception as error:  # not a ChoreoError: a bug in choreo, never a user's mistake
        if interrupted_inside(error):  # a compiled module's import stopped by Ctrl-C
            return interrupted()
        return report_bug(error, args.verbose)
    finally:
        gc.unfreeze()  # the collector's again: a program running many commands keeps no garbage


def program() -> int:
    """The ``choreo`` program (``choreo.cli.program`` loads this module, then calls this):
    :func:`main`, then, as the process is about to end, everything left is set aside from the
    collector: the interpreter's exit would walk it all once more (some 0.05 s of a ``choreo
    plan``)."""
    code = main()
    gc.freeze()
    return code


@contextmanager
def python_warnings_for_developers(verbose: int) -> Iterator[None]:
    """Python's warnings (numpy's "overflow encountered", a library's deprecation) are not
    shown: they speak of choreo's code, not the user's input, which choreo checks itself and
    reports in one line. ``-v`` shows them, for whoever debugs choreo."""
    with warnings.catch_warnings():
        if not verbose:
            warnings.simplefilter("ignore")
        yield


# MUJOCO_GL as the user set it (None: not set), while mujoco is imported without it.
_users_mujoco_gl: str | None = None


def unblock_stop_signals() -> None:
    """A parent may have blocked signals (the mask survives fork and exec): a choreo started so
    would never hear Ctrl-C, SIGTERM or SIGHUP, and could not be stopped. (Windows has no mask.)"""
    if hasattr(signal, "pthread_sigmask"):
        names = ("SIGINT", "SIGTERM", "SIGHUP")
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {getattr(signal, n) for n in names})


def put_aside_mujoco_gl() -> None:
    """mujoco reads MUJOCO_GL once, on import: it sets up that OpenGL context then (GLFW by
    default, which runs a subprocess to find its library) and refuses a name it does not know,
    which would stop even the commands that never draw. Only a render needs a back-end, and the
    preview chooses it then (choreo.preview.gl), so mujoco is imported without one and the
    user's choice waits for :func:`restore_mujoco_gl`. ``disable`` is taken as not set: it is
    what an earlier call left (the tests run many commands in one process)."""
    global _users_mujoco_gl
    given = os.environ.get("MUJOCO_GL")
    _users_mujoco_gl = None if given == "disable" else given
    os.environ["MUJOCO_GL"] = "disable"


def one_blas_thread() -> None:
    """numpy's OpenBLAS starts a thread per core as it loads, some 0.02 s of CPU that a busy
    2-core machine takes from the rest; choreo's matrices are small (a joint's Jacobian, the
    identify search's covariance), which BLAS works on in one thread anyway. Set before numpy
    is imported (by the command's modules); a user's own setting stands."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def restore_mujoco_gl() -> None:
    """MUJOCO_GL back as the user set it, for a render (once mujoco is imported)."""
    if _users_mujoco_gl is not None:
        os.environ["MUJOCO_GL"] = _users_mujoco_gl


def interrupted_inside(error: BaseException) -> bool:
    """Whether Ctrl-C is what ``error`` came from: a compiled module whose initialisation was
    interrupted fails as an ImportError caused by the KeyboardInterrupt."""
    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


EXIT_INTERNAL_ERROR = 70  # EX_SOFTWARE (sysexits.h): an internal software error


def report_bug(error: BaseException, verbose: int) -> int:
    """A bug: one line that says so, the traceback on stderr with -v, else in a file."""
    import tempfile  # (with shutil and random) only for a bug: not on every command's start

    trace = "".join(traceback.format_exception(error))
    where = "above"
    if verbose:
        print(trace, file=sys.stderr, end="")
    else:
        with tempfile.NamedTemporaryFile(
            "w", prefix="choreo-bug-", suffix=".txt", delete=False
        ) as file:
            file.write(trace)
        where = f"in {file.name}"
    print(
        f"choreo: internal error (a bug): {type(error).__name__}: {error}; please report it "
        f"with the traceback ({where})",
        file=sys.stderr,
    )
    return EXIT_INTERNAL_ERROR


# Library arguments whose flag is not their name with dashes (see flag_of).
FLAGS = {
    "health_timeout_s": "--health-timeout-ms",
    "link_path": "--pty",
    "current_id": "--id",
    "Recording.resume": "--resume",
    "width/height": "--size",
    "taught": "--joints",
    "render_preview": "-o FILE",
    "angle_deg": "--deg",  # choreo servo move
    "offset_deg": "--deg",  # choreo servo offset adjust
}


def flag_of(option: str) -> str:
    """The command-line flag of a library argument: ``exit_pose`` is ``--exit-pose``."""
    return FLAGS.get(option, "--" + option.replace("_", "-"))


def in_flags(text: str) -> str:
    """A library's note or warning as the command line says it: the arguments it names (a
    ``Worded`` text) spelled as flags, as errors are (``ChoreoError.worded``)."""
    return worded(text, flag_of)


def report_in_flags(document: object) -> object:
    """A JSON-ready report with every text in it :func:`in_flags`."""
    if isinstance(document, str):
        return in_flags(document)
    if isinstance(document, dict):
        return {key: report_in_flags(value) for key, value in document.items()}
    if isinstance(document, list | tuple):
        return [report_in_flags(value) for value in document]
    return document


def hint_for(error: ChoreoError) -> str | None:
    """What the command line offers for an error, where the library's words can't say it."""
    from choreo.bus.protocol import Command  # on an error only: --version stays light

    if (
        isinstance(error, BusError)
        and error.command is Command.OR_MOTOR_MODE_READ
        and error.servo_id is not None
    ):
        return f"stop its motor with `choreo servo motor --id {error.servo_id} --stop`"
    return None


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush doesn't fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
