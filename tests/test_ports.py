"""``choreo ports`` on fake port records (there is no hardware here): each known board named, with
the --port string to use; HID devices only when hidapi is there, and saying so when it is not."""

from __future__ import annotations

import functools
import json

from choreo.bus.ports import HidRecord, SerialRecord, list_ports
from choreo.cli import main, ports_commands

# USB IDs from the vendors' udev rules and drivers (see the README's table).
RRC = SerialRecord("/dev/ttyACM0", 0x1A86, 0x55D4, "USB Single Serial")
CH340 = SerialRecord("/dev/ttyUSB0", 0x1A86, 0x7523, "USB2.0-Serial")
FTDI = SerialRecord("/dev/ttyUSB1", 0x0403, 0x6001, "FT232R USB UART")
LOBOT = HidRecord("/dev/hidraw2", 0x0483, 0x5750, "LOBOT")
KEYBOARD = HidRecord("/dev/hidraw0", 0x046D, 0xC31C, "USB Keyboard")


def on_a_pi(*paths):
    present = {"/proc/device-tree/model", *paths}
    return present.__contains__


def by_device(listing):
    return {p.device: p for p in listing.ports}


def test_known_usb_devices_are_named_with_their_port_strings():
    listing = list_ports(
        lambda: [CH340, RRC, FTDI],
        lambda: [LOBOT, LOBOT, KEYBOARD],  # hidapi lists a device once per interface
        exists=lambda path: False,
    )
    ports = by_device(listing)
    assert list(ports) == [
        "/dev/ttyACM0",
        "/dev/ttyUSB0",
        "/dev/ttyUSB1",
        "/dev/hidraw2",
        "/dev/hidraw0",
    ]
    # generic WCH chips: either a bus adapter or an RRC board, and how to tell
    for device, usb_id, chip in (
        ("/dev/ttyACM0", "1a86:55d4", "CH9102"),
        ("/dev/ttyUSB0", "1a86:7523", "CH340"),
    ):
        port = ports[device]
        assert (port.usb_id, port.port_strings) == (usb_id, (device, f"rrc://{device}"))
        assert port.known_as.startswith(chip) and "bus adapter or a Hiwonder RRC" in port.known_as
        assert f"choreo ports --probe {device}" in port.note
    ftdi = ports["/dev/ttyUSB1"]
    assert (ftdi.known_as, ftdi.port_strings, ftdi.usb_id) == (None, ("/dev/ttyUSB1",), "0403:6001")
    lobot = ports["/dev/hidraw2"]
    assert (lobot.kind, lobot.usb_id, lobot.port_strings) == ("hid", "0483:5750", ("lobot://hid",))
    assert "LeArm's LSC-6" in lobot.note and "PWM servos" in lobot.note  # not a LOBOT bus arm
    assert "LeArm" not in lobot.known_as
    assert ports["/dev/hidraw0"].port_strings == ()  # a keyboard: listed, no --port
    assert listing.hid_missing is None


def test_pi_uarts_are_found_even_when_pyserial_leaves_them_out():
    listing = list_ports(
        lambda: [], lambda: [], exists=on_a_pi("/dev/ttyAMA0", "/dev/ttyTHS1", "/dev/rrc")
    )
    ports = by_device(listing)
    assert list(ports) == ["/dev/rrc", "/dev/ttyAMA0", "/dev/ttyTHS1"]
    assert ports["/dev/ttyAMA0"].port_strings == (
        "/dev/ttyAMA0 --direction PRESET",
        "rrc:///dev/ttyAMA0",
    )
    assert "tonypi" in ports["/dev/ttyAMA0"].note and "TonyPi" in ports["/dev/ttyAMA0"].known_as
    assert "JetHexa" in ports["/dev/ttyTHS1"].known_as
    assert ports["/dev/rrc"].port_strings == ("rrc:///dev/rrc",)


def test_a_pcs_serial_port_is_not_taken_for_a_robots_uart():
    pc_port = SerialRecord("/dev/ttyS0")
    (port,) = list_ports(lambda: [pc_port], lambda: [], exists=lambda path: False).ports
    assert (port.known_as, port.port_strings) == (None, ("/dev/ttyS0",))
    (port,) = list_ports(lambda: [pc_port], lambda: [], exists=on_a_pi("/dev/ttyS0")).ports
    assert "ArmPi Pro" in port.known_as and len(port.port_strings) == 2


def test_without_hidapi_the_listing_says_so_and_names_the_extra():
    def no_hidapi():
        raise ModuleNotFoundError("No module named 'hid'")

    listing = list_ports(lambda: [RRC], no_hidapi, exists=lambda path: False)
    assert [p.device for p in listing.ports] == ["/dev/ttyACM0"]
    assert "hidapi" in listing.hid_missing and "choreo[lobot]" in listing.hid_missing


def fake_system(monkeypatch, serial_records, hid_records):
    fake = functools.partial(
        list_ports, lambda: serial_records, lambda: hid_records, exists=lambda path: False
    )
    monkeypatch.setattr(ports_commands, "list_ports", fake)


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
