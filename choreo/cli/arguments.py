"""Argument types and option groups shared by the commands, and the built-in emulated bus."""

from __future__ import annotations

import argparse
import sys

from ..bus import ServoBus
from ..clock import RealClock
from ..emulator import BusEmulator, ServoSpec
from ..protocol import MAX_SERVO_ID, parse_ids
from ..robot import Robot

BUILT_IN_PORT = "sim://?ids=1-6"


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def positive_int(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return int(text)


def servo_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SERVO_ID:
        raise argparse.ArgumentTypeError(f"a servo ID is a whole number 0-{MAX_SERVO_ID}, got {text!r}")
    return value


def id_ranges(text: str) -> tuple[int, ...]:
    try:
        return parse_ids(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_planning_arguments(parser: argparse.ArgumentParser) -> None:
    """--speed, --stretch, --tolerance: how a motion is planned and compiled (plan, preview, play)."""
    parser.add_argument("--speed", type=positive_float,
                        help="time scale (overrides the file's speed): 2 plays twice as fast")
    parser.add_argument("--stretch", action="store_true",
                        help="move keyframes later where the limits can't meet their times "
                             "(and say by how much) instead of failing")
    parser.add_argument("--tolerance", type=positive_float, default=0.5, metavar="DEG",
                        help="how far the servos' linear moves may leave the smooth plan "
                             "(default 0.5°; rounding to whole servo units adds up to 0.12°)")


def add_port_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", help="serial port or pyserial URL (default: the built-in "
                        f"emulated bus, {BUILT_IN_PORT}); e.g. /dev/ttyUSB0, COM3, sim://?ids=1-18")
    parser.add_argument("--timeout-ms", type=positive_float, default=50.0,
                        help="per-read timeout (default 50 ms; USB adapters add latency)")
    parser.add_argument("--retries", type=int, default=2, choices=range(0, 10), metavar="N",
                        help="retries per read, 0-9 (default 2)")
    parser.add_argument("--echo", choices=("none", "discard", "auto"), default="auto",
                        help="does the adapter echo the host's bytes (one-wire wiring)? default auto")


def open_bus(args: argparse.Namespace, *, built_in: str = BUILT_IN_PORT) -> ServoBus:
    """The bus the user asked for; without --port, the built-in emulator (and say so)."""
    port = args.port
    if port is None:
        port = built_in
        print(f"no --port given: using the built-in emulated bus ({port})", file=sys.stderr)
    return ServoBus(port, timeout_s=args.timeout_ms / 1000, retries=args.retries, echo=args.echo)


def built_in_emulator(robot: Robot) -> BusEmulator:
    """The robot's servos on an emulated bus in real time, standing at its home pose."""
    home = robot.pose_vector("home")
    specs = [ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
             for j, a in zip(robot.joints, home)]
    return BusEmulator(specs, clock=RealClock())
