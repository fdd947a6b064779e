"""``choreo scan``: what is on the bus; the port options and bus opening every bus command shares
(``choreo servo`` lives in ``servo_commands``)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from rich.console import Console
from rich.table import Table

from ..bus import ServoBus
from ..protocol import MAX_SERVO_ID, parse_ids
from ..servos import DEG_PER_UNIT

BUILT_IN_PORT = "sim://?ids=1-6"


def register(subparsers) -> None:
    scan = subparsers.add_parser("scan", help="list the servos that answer on the bus")
    add_port_arguments(scan)
    scan.add_argument("--ids", type=id_ranges, default=tuple(range(MAX_SERVO_ID + 1)),
                      metavar="RANGE", help="IDs to try, e.g. 1-18 (default 0-253)")
    scan.add_argument("--json", action="store_true", help="machine-readable output")
    scan.set_defaults(handler=run_scan)


def add_port_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", help="serial port or pyserial URL (default: the built-in "
                        f"emulated bus, {BUILT_IN_PORT}); e.g. /dev/ttyUSB0, COM3, sim://?ids=1-18")
    parser.add_argument("--timeout-ms", type=float, default=50.0,
                        help="per-read timeout (default 50 ms; USB adapters add latency)")
    parser.add_argument("--retries", type=int, default=2, help="retries per read (default 2)")
    parser.add_argument("--echo", choices=("none", "discard", "auto"), default="auto",
                        help="does the adapter echo the host's bytes (one-wire wiring)? default auto")


def open_bus(args: argparse.Namespace, *, built_in: str = BUILT_IN_PORT) -> ServoBus:
    """The bus the user asked for; without --port, the built-in emulator (and say so)."""
    port = args.port
    if port is None:
        port = built_in
        print(f"no --port given: using the built-in emulated bus ({port})", file=sys.stderr)
    return ServoBus(port, timeout_s=args.timeout_ms / 1000, retries=args.retries, echo=args.echo)


def id_ranges(text: str) -> tuple[int, ...]:
    try:
        return parse_ids(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def servo_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SERVO_ID:
        raise argparse.ArgumentTypeError(f"a servo ID is a whole number 0-{MAX_SERVO_ID}, got {text!r}")
    return value


def run_scan(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        found = bus.scan(args.ids)
        statuses = [bus.read_status(i) for i in found]
    if args.json:
        print(json.dumps([dataclasses.asdict(s) for s in statuses], indent=2))
        return 0
    if not statuses:
        print(f"no servo answered on IDs {_describe(args.ids)}: check power (the servos need their "
              "own supply), wiring and baud rate (115200)")
        return 1
    table = Table(title=f"{len(statuses)} servo(s) on {bus.name}")
    for column in ("id", "position", "angle", "vin", "temp"):
        table.add_column(column, justify="right")
    for s in statuses:
        table.add_row(str(s.servo_id), f"{s.pos_units}", f"{s.pos_units * DEG_PER_UNIT:.1f}°",
                      f"{s.vin_mv / 1000:.2f} V", f"{s.temp_c} °C")
    Console().print(table)
    return 0


def _describe(ids: tuple[int, ...]) -> str:
    return f"{ids[0]}-{ids[-1]}" if ids == tuple(range(ids[0], ids[-1] + 1)) else ",".join(map(str, ids))
