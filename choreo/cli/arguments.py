"""Argument types and option groups shared by the commands, the built-in emulated bus, and
loading a motion that dances to a song."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from choreo.bus.protocol import MAX_SERVO_ID, parse_id_sequence, parse_ids
from choreo.bus.settings import BUILT_IN_PORT, MAX_RETRIES, MAX_TIMEOUT_MS, TIMEOUT_S, BusSettings
from choreo.core.arguments import COUNT, NON_NEGATIVE, NUMBER, POSITIVE, Range

if TYPE_CHECKING:
    from choreo.bus.servo_bus import ServoBus
    from choreo.motion.motion_file import Motion
    from choreo.plan.pipeline import PlanOptions
    from choreo.robot.types import Robot


def number_in(valid: Range) -> Callable[[str], float]:
    """The argparse type of a number in ``valid``: the range the library checks the same
    argument against, so the flag and the argument accept the same values."""

    def parse(text: str) -> float:
        try:
            value = valid.number(int(text) if valid.whole else float(text))
        except ValueError:
            value = None
        if value is None:
            raise argparse.ArgumentTypeError(f"expected {valid}, got {text!r}")
        return value

    return parse


finite_float = number_in(NUMBER)
non_negative_float = number_in(NON_NEGATIVE)
positive_float = number_in(POSITIVE)


def positive_int(text: str) -> int:
    return int(number_in(COUNT)(text))


def float_in(low: float, high: float, unit: str = "") -> Callable[[str], float]:
    """A number in (low, high]: options whose huge values would overflow a timer."""
    return number_in(Range(above=low, at_most=high, unit=unit))


def servo_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SERVO_ID:
        raise argparse.ArgumentTypeError(
            f"a servo ID is a whole number 0-{MAX_SERVO_ID}, got {text!r}"
        )
    return value


def id_ranges(text: str) -> tuple[int, ...]:
    """IDs to address, sorted and unique."""
    try:
        return parse_ids(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _direction(text: str) -> str:
    from choreo.bus.transports.direction import parse_direction  # the transports: bus commands

    try:
        parse_direction(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def id_sequence(text: str) -> tuple[int, ...]:
    """IDs in the order written: one per column of a file, say."""
    try:
        return parse_id_sequence(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


# Closing the terminal or losing the SSH link (SIGHUP) and `kill` (SIGTERM) must stop the servos
# and leave them in a known state exactly as Ctrl-C does.
STOP_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


@contextlib.contextmanager
def stop_signals_as_ctrl_c() -> Iterator[None]:
    """Inside, SIGTERM and SIGHUP raise KeyboardInterrupt as Ctrl-C does; restored after."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = {signum: signal.signal(signum, interrupt) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


# The modules each handler imports where it runs (see loads)
_HANDLER_MODULES: dict[Callable[[argparse.Namespace], int], tuple[str, ...]] = {}


def loads(*modules: str) -> Callable[[Callable[[argparse.Namespace], int]], Callable]:
    """A command's handler that imports ``modules`` inside, not at its module's top, so that
    ``choreo --help`` (which imports every command module to list them) does not load them.
    ``main`` loads them before it calls the handler, as it loads the command's module: the
    collector paused, Ctrl-C, SIGTERM and SIGHUP deferred (see :func:`handler_modules`)."""

    def mark(handler: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
        _HANDLER_MODULES[handler] = modules
        return handler

    return mark


def handler_modules(handler: Callable[[argparse.Namespace], int]) -> tuple[str, ...]:
    """The modules ``handler`` was marked as importing where it runs (:func:`loads`)."""
    return _HANDLER_MODULES.get(handler, ())


@contextlib.contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """Inside, Ctrl-C, SIGTERM and SIGHUP wait for the block to end, then raise
    KeyboardInterrupt. Around the import of a compiled extension (mujoco): interrupted in its
    initialisation, it fails as an ImportError (a bug, as choreo sees it), and Python, having
    seen the interrupt pass through its own code, ends by the signal after choreo has exited
    130."""
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread receives signals
        return
    held: list[int] = []
    signums = (signal.SIGINT, *STOP_SIGNALS)
    previous = {signum: signal.signal(signum, lambda n, _: held.append(n)) for signum in signums}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if held:
        raise KeyboardInterrupt


def file_path(text: str) -> Path:
    """A file's path as typed: an empty one is refused (as a Path it would be ".", the current
    folder, and the refusal would speak of a folder no one named)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the path is empty: give a file's path")
    return Path(text)


def add_output_arguments(parser: argparse.ArgumentParser, metavar: str, help_text: str) -> None:
    """-o/--output FILE and --overwrite, for commands that write one file."""
    parser.add_argument(
        "-o", "--output", type=file_path, required=True, metavar=metavar, help=help_text
    )
    parser.add_argument("--overwrite", action="store_true", help=f"replace an existing {metavar}")


def add_planning_arguments(parser: argparse.ArgumentParser) -> None:
    """--speed, --stretch, --tolerance: how a motion is planned and compiled (plan, preview,
    play)."""
    from choreo.motion.timing import SPEED  # these commands plan: no extra cost
    from choreo.plan.ticks import (  # the planner's world: not for bus commands
        DEFAULT_TOLERANCE_DEG,
        TOLERANCE_DEG,
    )

    parser.add_argument(
        "--speed",
        type=number_in(SPEED),
        help=f"time scale, {SPEED.at_least:g}..{SPEED.at_most:g} (overrides the file's speed): "
        "2 plays twice as fast",
    )
    parser.add_argument(
        "--stretch",
        action="store_true",
        help="move keyframes later where the limits can't meet their times "
        "(and say by how much) instead of failing",
    )
    add_past_song_argument(parser)
    parser.add_argument(
        "--tolerance",
        type=number_in(TOLERANCE_DEG),
        default=DEFAULT_TOLERANCE_DEG,
        metavar="DEG",
        help="how far the servos' linear moves may leave the smooth plan, up to "
        f"{TOLERANCE_DEG.at_most:g}° (default {DEFAULT_TOLERANCE_DEG:g}°; rounding to whole "
        "servo units adds up to 0.12°)",
    )


def plan_options(args: argparse.Namespace) -> PlanOptions:
    """--speed, --stretch and --tolerance (``add_planning_arguments``) as the library takes them."""
    from choreo.plan.pipeline import PlanOptions

    return PlanOptions(speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance)


def add_past_song_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--allow-past-song",
        action="store_true",
        help="with music: let the dance run on after its song ends (warned, not refused)",
    )


def add_port_arguments(parser: argparse.ArgumentParser) -> None:
    """--port, --timeout-ms, --retries, --echo; unset ones come from the robot file's ``bus:``
    section where a robot is involved, else from the defaults."""
    from choreo.bus.transports.direction import PRESETS  # the transports: bus commands only

    defaults = BusSettings()
    parser.add_argument(
        "--port",
        help="serial port or pyserial URL, e.g. /dev/ttyUSB0, COM3, "
        "sim://?ids=1-18; through a controller board rrc:///dev/ttyAMA0, lobot://hid, "
        "lobot:///dev/ttyUSB0 (default: the robot file's bus port, else the built-in "
        "emulated bus)",
        type=port_string,
    )
    parser.add_argument(
        "--timeout-ms",
        type=number_in(TIMEOUT_S.scaled(1000, " ms")),
        help=f"per-read timeout, up to {MAX_TIMEOUT_MS:g} (default "
        f"{defaults.timeout_s * 1000:g} ms; USB adapters add latency)",
    )
    parser.add_argument(
        "--retries",
        type=int,
        choices=range(0, MAX_RETRIES + 1),
        metavar="N",
        help=f"retries per read, 0-{MAX_RETRIES} (default {defaults.retries})",
    )
    parser.add_argument(
        "--echo",
        choices=("none", "discard", "auto"),
        help=f"does the adapter echo the host's bytes (one-wire wiring)? (default {defaults.echo})",
    )
    parser.add_argument(
        "--direction",
        type=_direction,
        metavar="PINS",
        help="GPIO half-duplex direction lines of a Pi/Jetson UART: "
        f"{', '.join(PRESETS)}, or rx=N,tx=N[,chip=PATH] (needs choreo[pi])",
    )


def port_string(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError(
            f"expected a port such as /dev/ttyUSB0, COM3 or sim:// (list them with `choreo "
            f"ports`), got {text!r}"
        )
    return text


def bus_settings(args: argparse.Namespace, robot: Robot | None = None) -> BusSettings:
    """The command line over the robot file's ``bus:`` section over the defaults."""
    base = robot.bus if robot is not None else BusSettings()
    return BusSettings(
        port=args.port if args.port is not None else base.port,
        timeout_s=args.timeout_ms / 1000 if args.timeout_ms is not None else base.timeout_s,
        retries=args.retries if args.retries is not None else base.retries,
        echo=args.echo if args.echo is not None else base.echo,
        direction=args.direction if args.direction is not None else base.direction,
    )


def open_bus(args: argparse.Namespace) -> ServoBus:
    """The bus the user asked for; without --port, the built-in emulator's servos 1-6 (and say
    so)."""
    from choreo.bus.servo_bus import ServoBus  # when a command runs, not for its --help

    settings = bus_settings(args)
    if settings.port is None:
        print(
            f"no --port given: using the built-in emulated bus ({BUILT_IN_PORT})", file=sys.stderr
        )
    return ServoBus.from_settings(settings)


def say_built_in_emulator(robot: Robot, doing: str) -> None:
    """Tell that no port was named anywhere, so the built-in emulator's servos are used."""
    print(
        f"no --port given: {doing} the built-in emulated bus ({len(robot.joints)} servos "
        f"of {robot.name} at its home pose)",
        file=sys.stderr,
    )


def load_dance(path: Path, allow_past_song: bool) -> Motion:
    """The motion, saying on stderr which detected beats ``beats: auto`` took and (allowed) that
    the dance outlasts its song; not allowed, ``load_motion`` has refused it at its line."""
    from choreo.motion.dance import dance_of  # the planner's world: not for bus commands

    return dance_of(
        path, allow_past_song, on_note=lambda text: print(f"choreo: {text}", file=sys.stderr)
    )
