"""``choreo ports`` on fake port records (there is no hardware here): each known board named, with
the --port string to use; HID devices only when hidapi is there, and saying so when it is not."""

from __future__ import annotations

from ports_helpers import CH340, LOBOT, RRC

from choreo.bus.ports import HidRecord, SerialRecord, list_ports

FTDI = SerialRecord("/dev/ttyUSB1", 0x0403, 0x6001, "FT232R USB UART")
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
