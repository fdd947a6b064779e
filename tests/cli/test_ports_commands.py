"""choreo ports as a user runs it: each port with the --port string to paste, in text and JSON."""

from __future__ import annotations

import json

from ports_helpers import CH340, LOBOT, RRC, fake_system

from choreo.bus.ports import SerialRecord
from choreo.cli import main


def test_the_command_prints_each_port_and_its_port_string(monkeypatch, capsys):
    fake_system(monkeypatch, [RRC, CH340], [LOBOT])
    assert main(["ports"]) == 0
    out = capsys.readouterr().out
    assert "/dev/ttyACM0 [1a86:55d4]  CH9102 USB serial chip: a BusLinker-style" in out
    assert "    --port /dev/ttyACM0\n    --port rrc:///dev/ttyACM0\n" in out
    assert "    --port /dev/ttyUSB0\n" in out
    assert (
        "/dev/hidraw2 [0483:5750]  LOBOT Bus Servo Controller (xArm)\n    --port lobot://hid" in out
    )


def test_the_command_in_json(monkeypatch, capsys):
    fake_system(monkeypatch, [RRC], [LOBOT])
    assert main(["ports", "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert document["hid_listed"] is True
    assert [(p["device"], p["port_strings"]) for p in document["ports"]] == [
        ("/dev/ttyACM0", ["/dev/ttyACM0", "rrc:///dev/ttyACM0"]),
        ("/dev/hidraw2", ["lobot://hid"]),
    ]


def test_no_serial_port_says_what_to_check(monkeypatch, capsys):
    fake_system(monkeypatch, [], [])
    assert main(["ports"]) == 0
    assert "no serial ports found" in capsys.readouterr().out


def test_a_port_string_the_shell_would_split_is_printed_quoted(monkeypatch, capsys):
    odd = SerialRecord("/dev/serial/by-id/usb-WCH CH340 (arm)", 0x1A86, 0x7523, "USB2.0-Serial")
    fake_system(monkeypatch, [odd], [])
    assert main(["ports"]) == 0
    out = capsys.readouterr().out
    assert "    --port '/dev/serial/by-id/usb-WCH CH340 (arm)'\n" in out
    assert "    --port 'rrc:///dev/serial/by-id/usb-WCH CH340 (arm)'\n" in out
    assert "choreo ports --probe '/dev/serial/by-id/usb-WCH CH340 (arm)'`" in out
