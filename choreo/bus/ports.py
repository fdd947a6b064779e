"""Which ports could reach servos, and the ``--port`` string for each (``choreo ports``).

Serial ports come from pyserial's enumeration, HID devices from hidapi when it is installed (the
``lobot`` extra), and the Raspberry Pi / Jetson UARTs the vendors' robots use from the device
files themselves (pyserial leaves some of them out). Each is named from its USB VID:PID or its
path, as the vendors' SDKs and udev rules give them (README, "Finding the port"). The
enumerations are plain functions passed in, so tests feed fake records: there is no hardware.
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

LOBOT_USB_ID = (0x0483, 0x5750)  # LOBOT Bus Servo Controller, USB HID only
# Generic WCH USB-serial chips: the ID names the chip, not what it is built into. The RRC board
# enumerates as a CH9102 (1a86:55d4, the vendor's udev rule), a JetArm controller has been seen as
# a CH340, and BusLinker-style bus adapters use either.
GENERIC_USB_CHIPS: dict[tuple[int | None, int | None], str] = {
    (0x1A86, 0x55D4): "CH9102",
    (0x1A86, 0x7523): "CH340",
}
PROBE_HINT = (
    "tell which with `choreo ports --probe {device}`: an RRC board sends battery frames at "
    "1,000,000 baud, servos on a raw bus answer an ID read at 115200"
)
LOBOT_EXTRA = "pip install 'choreo[lobot]'"

# The UARTs of the Pi / Jetson robots (docs/transports.md): the raw bus through the HAT's
# direction pins, or, on newer robots, the RRC board on the same UART.
PI_UARTS = {
    "/dev/ttyAMA0": "TonyPi, SpiderPi, AiNex on a Raspberry Pi",
    "/dev/serial0": "SpiderPi",
    "/dev/ttyS0": "ArmPi Pro",
    "/dev/ttyTHS1": "JetHexa, AiNex on a Jetson",
}
RRC_LINKS = ("/dev/rrc",)  # the udev link PuppyPi's rules make for the RRC board
DEVICE_TREE_MODEL = "/proc/device-tree/model"  # present on a Pi or a Jetson, not on a PC
DIRECTION_PRESETS = "tonypi, spiderpi, armpi-pro, jethexa, ainex"


@dataclass(frozen=True)
class SerialRecord:
    """One serial port as the system lists it."""

    device: str
    vid: int | None = None
    pid: int | None = None
    description: str = ""


@dataclass(frozen=True)
class HidRecord:
    """One USB HID device as hidapi lists it."""

    path: str
    vid: int
    pid: int
    product: str = ""


@dataclass(frozen=True)
class FoundPort:
    """A port, what it probably is, and the ``--port`` strings that would use it."""

    kind: str  # "serial" or "hid"
    device: str
    usb_id: str | None  # "1a86:55d4"
    description: str
    known_as: str | None  # None: nothing choreo knows
    port_strings: tuple[str, ...]
    note: str = ""


@dataclass(frozen=True)
class PortListing:
    ports: tuple[FoundPort, ...]
    hid_missing: str | None  # why HID devices are not listed (None: they are)


def list_ports(
    serial_ports: Callable[[], Iterable[SerialRecord]] | None = None,
    hid_devices: Callable[[], Iterable[HidRecord]] | None = None,
    exists: Callable[[str], bool] = os.path.exists,
) -> PortListing:
    """Every port found, serial first. Each source can be replaced (tests, other systems)."""
    serial_records = list((serial_ports or system_serial_ports)())
    listed = {r.device for r in serial_records}
    on_board = exists(DEVICE_TREE_MODEL)  # a PC's /dev/ttyS0 is no robot's UART
    extra = [*(PI_UARTS if on_board else ()), *RRC_LINKS]
    serial_records += [SerialRecord(p) for p in extra if p not in listed and exists(p)]
    hid_missing = None
    hid_records: list[HidRecord] = []
    try:
        hid_records = list((hid_devices or system_hid_devices)())
    except ModuleNotFoundError:
        hid_missing = (
            f"HID devices not listed: the hidapi package is not installed ({LOBOT_EXTRA}); "
            "the LOBOT Bus Servo Controller of the xArm is a USB HID device"
        )
    return PortListing(
        tuple(
            identify_serial(r, on_board=on_board)
            for r in sorted(serial_records, key=lambda r: r.device)
        )
        + tuple(identify_hid(r) for r in _unique(hid_records)),
        hid_missing,
    )


def identify_serial(record: SerialRecord, *, on_board: bool) -> FoundPort:
    """``on_board``: this computer is a Pi or Jetson, so its UARTs may be a robot's bus."""
    device, usb = record.device, _usb_id(record.vid, record.pid)

    def found(known_as, port_strings, note=""):
        return FoundPort("serial", device, usb, record.description, known_as, port_strings, note)

    if device in RRC_LINKS:
        return found("Hiwonder RRC controller board (STM32)", (f"rrc://{device}",))
    chip = GENERIC_USB_CHIPS.get((record.vid, record.pid))
    if chip is not None:
        return found(
            f"{chip} USB serial chip: a BusLinker-style bus adapter or a Hiwonder RRC "
            "controller board",
            (device, f"rrc://{device}"),
            "the raw LX bus at 115200 baud, or the RRC board at 1,000,000 baud; "
            + PROBE_HINT.format(device=shlex.quote(device)),
        )
    if on_board and device in PI_UARTS:
        return found(
            f"the UART of {PI_UARTS[device]}",
            (f"{device} --direction PRESET", f"rrc://{device}"),
            f"the raw bus through the HAT's direction pins, PRESET one of {DIRECTION_PRESETS}; "
            "or rrc:// on robots with the RRC controller board (newer TonyPi, SpiderPi)",
        )
    if usb is not None:
        return found(None, (device,), "a USB serial adapter: the raw LX bus if it is one")
    return found(None, (device,), "")


def identify_hid(record: HidRecord) -> FoundPort:
    usb = _usb_id(record.vid, record.pid)
    if (record.vid, record.pid) == LOBOT_USB_ID:
        return FoundPort(
            "hid",
            record.path,
            usb,
            record.product,
            "LOBOT Bus Servo Controller (xArm)",
            ("lobot://hid",),
            "a LeArm's LSC-6 board has the same USB ID, but drives PWM servos by pulse width and "
            "cannot read positions: choreo cannot play it; `choreo ports --probe lobot://hid` "
            "tells them apart (the LOBOT controller's bus servos answer a position read)",
        )
    return FoundPort("hid", record.path, usb, record.product, None, ())


def system_serial_ports() -> list[SerialRecord]:
    from serial.tools import list_ports  # pyserial; only this command enumerates

    return [
        SerialRecord(p.device, p.vid, p.pid, p.description if p.description != "n/a" else "")
        for p in list_ports.comports()
    ]


def system_hid_devices() -> list[HidRecord]:
    """ModuleNotFoundError when hidapi is not installed."""
    import hid  # the hidapi package: choreo[lobot]

    return [
        HidRecord(
            _text(d.get("path")),
            d.get("vendor_id", 0),
            d.get("product_id", 0),
            d.get("product_string") or "",
        )
        for d in hid.enumerate()
    ]


def _unique(records: Sequence[HidRecord]) -> list[HidRecord]:
    """hidapi lists a device once per interface: keep one entry per VID:PID and product."""
    seen: dict[tuple[int, int, str], HidRecord] = {}
    for record in records:
        seen.setdefault((record.vid, record.pid, record.product), record)
    return list(seen.values())


def _usb_id(vid: int | None, pid: int | None) -> str | None:
    return f"{vid:04x}:{pid:04x}" if vid is not None and pid is not None else None


def _text(path: bytes | str | None) -> str:
    return path.decode(errors="replace") if isinstance(path, bytes) else path or ""
