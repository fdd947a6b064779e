"""``choreo ports``: the serial ports and HID devices here, and the ``--port`` string for each
(shell-quoted: ``sim://?board=rrc&ids=1-6`` pasted bare would run in the background)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import shlex

from choreo.bus.ports import FoundPort, list_ports
from choreo.bus.probe import ProbeResult, probe_port


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "ports",
        help="list serial ports and USB HID devices, naming known servo boards",
        description="List serial ports and USB HID devices with their USB VID:PID, name the "
        "servo adapters and controller boards choreo knows, and print the --port string to "
        "use for each. Nothing is opened unless --probe is given.",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.add_argument(
        "--probe",
        nargs="*",
        metavar="PORT",
        help="tell what is behind each port (every listed port if none is named) by listening "
        "and sending reads only: an RRC board's battery frames at 1,000,000 baud, the LOBOT "
        "controller's battery read at 9600, a broadcast ID read at 115200; a few seconds per port",
    )
    parser.set_defaults(handler=run_ports)


def run_ports(args: argparse.Namespace) -> int:
    if args.probe is not None:
        return _run_probe(args.probe or _probe_targets(), as_json=args.json)
    listing = list_ports()
    if args.json:
        document = {
            "ports": [dataclasses.asdict(p) for p in listing.ports],
            "hid_listed": listing.hid_missing is None,
        }
        print(json.dumps(document, indent=2))
        return 0
    for port in listing.ports:
        print(_describe(port))
    if not any(p.kind == "serial" for p in listing.ports):
        print("no serial ports found: plug the adapter in (and check `dmesg` for it)")
    if listing.hid_missing:
        print(listing.hid_missing)
    return 0


def _describe(port: FoundPort) -> str:
    usb = f" [{port.usb_id}]" if port.usb_id else ""
    what = port.known_as or port.description or ("HID device" if port.kind == "hid" else "")
    lines = [f"{port.device}{usb}  {what}".rstrip()]
    lines += [f"    --port {shlex.quote(text)}" for text in port.port_strings]
    if port.note:
        lines.append(f"    ({port.note})")
    return "\n".join(lines)


def _probe_targets() -> list[str]:
    """Every listed serial port, and the LOBOT controller over HID when one is listed."""
    ports = list_ports().ports
    targets = [p.device for p in ports if p.kind == "serial"]
    return targets + sorted({s for p in ports if p.kind == "hid" for s in p.port_strings})


def _run_probe(targets: list[str], *, as_json: bool) -> int:
    results = [probe_port(target) for target in targets]
    if as_json:
        print(json.dumps({"probed": [dataclasses.asdict(r) for r in results]}, indent=2))
        return 0
    for result in results:
        print(_describe_probe(result))
    if not results:
        print("no ports to probe: plug the adapter in (and check `dmesg` for it)")
    return 0


def _describe_probe(result: ProbeResult) -> str:
    if result.transport is None or result.port_string is None:
        return f"{result.device}  nothing found\n    ({result.note})"
    found = [result.transport]
    if result.battery_mv is not None:
        found.append(f"supply {result.battery_mv / 1000:.1f} V")
    if result.servo_ids is not None:
        ids = ", ".join(map(str, result.servo_ids))
        found.append(f"servo IDs {ids}" if ids else "no servo answered")
    lines = [
        f"{result.device}  {', '.join(found)}",
        f"    --port {shlex.quote(result.port_string)}",
    ]
    if result.note:
        lines.append(f"    ({result.note})")
    return "\n".join(lines)
