"""``choreo scan``: what is on the bus (``choreo servo`` lives in ``servo_commands``)."""

from __future__ import annotations

import argparse
import dataclasses
import json
from typing import TYPE_CHECKING

from choreo.bus.protocol import MAX_SERVO_ID
from choreo.bus.servo_models import DEG_PER_UNIT
from choreo.bus.transports import RAW
from choreo.cli.arguments import add_port_arguments, id_ranges, open_bus

if TYPE_CHECKING:
    from choreo.bus.servo_bus import ScanResult, ServoBus


def register(subparsers) -> None:
    scan = subparsers.add_parser(
        "scan",
        help="list the servos that answer on the bus",
        description="Try each ID with ID_READ, --retries more times when no valid reply comes "
        "back: an absent ID costs --timeout-ms × (1 + --retries); use --retries 0 for a quick "
        "look.",
    )
    add_port_arguments(scan)
    scan.add_argument(
        "--ids",
        type=id_ranges,
        default=tuple(range(MAX_SERVO_ID + 1)),
        metavar="RANGE",
        help="IDs to try, e.g. 1-18 (default 0-253)",
    )
    scan.add_argument("--json", action="store_true", help="machine-readable output")
    scan.set_defaults(handler=run_scan)


def run_scan(args: argparse.Namespace) -> int:
    # rich is imported when the command runs: `choreo scan --help` starts without it.
    from rich.console import Console
    from rich.table import Table

    with open_bus(args) as bus:
        # --retries counts here as for every read: one damaged reply must not make a present
        # servo look like two servos sharing its ID.
        scan = scan_with_progress(bus, args.ids)
        statuses = [bus.read_status(i) for i in scan.found]
        transport = bus.capabilities.transport
    if args.json:
        print(
            json.dumps(
                {
                    "servos": [dataclasses.asdict(s) for s in statuses],
                    "garbled_ids": list(scan.garbled),
                },
                indent=2,
            )
        )
        return 0
    for servo_id in scan.garbled:
        print(
            f"ID {servo_id}: replies garbled: several servos share this ID (give them their own "
            "IDs one at a time with `choreo servo set-id`), or the wiring is noisy"
        )
    if not statuses:
        if not scan.garbled:
            print(
                f"no servo answered on IDs {_describe(args.ids)}: check power (the servos need "
                f"their own supply), {_what_to_check(transport)}"
            )
        return 1
    table = Table(title=f"{len(statuses)} servo(s) on {bus.name}")
    for column in ("id", "position", "angle", "vin", "temp"):
        table.add_column(column, justify="right")
    for s in statuses:
        table.add_row(
            str(s.servo_id),
            f"{s.pos_units}",
            f"{s.pos_units * DEG_PER_UNIT:.1f}°",
            "-" if s.vin_mv is None else f"{s.vin_mv / 1000:.2f} V",
            "-" if s.temp_c is None else f"{s.temp_c} °C",
        )
    Console().print(table)
    if None in (statuses[0].vin_mv, statuses[0].temp_c):
        print(f"-: the {bus.capabilities.transport} cannot read this")
    return 0


def scan_with_progress(bus: ServoBus, ids: tuple[int, ...]) -> ScanResult:
    """``bus.scan_presence`` one ID at a time, with a progress bar on stderr when it is a
    terminal: a full 0-253 scan waits out a timeout per absent ID, seconds in all."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    from choreo.bus.servo_bus import ScanResult

    console = Console(stderr=True)
    found: list[int] = []
    garbled: list[int] = []
    columns = (
        TextColumn("scanning {task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[found]}"),
    )
    with Progress(
        *columns, console=console, transient=True, disable=not console.is_terminal
    ) as progress:
        task = progress.add_task("", total=len(ids), found="")
        for servo_id in ids:
            progress.update(task, description=f"ID {servo_id}")
            one = bus.scan_presence([servo_id], retries=bus.retries)
            found += one.found
            garbled += one.garbled
            progress.update(task, advance=1, found=f"{len(found)} found" if found else "")
    return ScanResult(found=tuple(found), garbled=tuple(garbled))


def _what_to_check(transport: str) -> str:
    """Beyond power: a raw bus runs at 115200 baud; a board sets its own link's rate."""
    if transport == RAW.transport:
        return "wiring and baud rate (115200)"
    return f"that the servos are plugged into the {transport} and the board is switched on"


def _describe(ids: tuple[int, ...]) -> str:
    return (
        f"{ids[0]}-{ids[-1]}"
        if ids == tuple(range(ids[0], ids[-1] + 1))
        else ",".join(map(str, ids))
    )
