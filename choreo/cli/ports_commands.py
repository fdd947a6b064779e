"""``choreo ports``: the serial ports and HID devices here, and the ``--port`` string for each."""

from __future__ import annotations

import argparse
import dataclasses
import json

from choreo.bus.ports import FoundPort, list_ports


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "ports",
        help="list serial ports and USB HID devices, naming known servo boards",
        description="List serial ports and USB HID devices with their USB VID:PID, name the "
        "servo adapters and controller boards choreo knows, and print the --port string to "
        "use for each. Nothing is opened.",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(handler=run_ports)


def run_ports(args: argparse.Namespace) -> int:
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
    lines += [f"    --port {text}" for text in port.port_strings]
    if port.note:
        lines.append(f"    ({port.note})")
    return "\n".join(lines)
