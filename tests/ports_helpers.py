"""A machine's serial and HID ports, faked, so the port listing can be tested anywhere."""

from __future__ import annotations

import functools

from choreo.bus.ports import HidRecord, SerialRecord, list_ports
from choreo.cli import ports_commands

# USB IDs from the vendors' udev rules and drivers (see the README's table).
RRC = SerialRecord("/dev/ttyACM0", 0x1A86, 0x55D4, "USB Single Serial")


CH340 = SerialRecord("/dev/ttyUSB0", 0x1A86, 0x7523, "USB2.0-Serial")


LOBOT = HidRecord("/dev/hidraw2", 0x0483, 0x5750, "LOBOT")


def fake_system(monkeypatch, serial_records, hid_records):
    fake = functools.partial(
        list_ports, lambda: serial_records, lambda: hid_records, exists=lambda path: False
    )
    monkeypatch.setattr(ports_commands, "list_ports", fake)
