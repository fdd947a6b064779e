"""Transports: what sits between the host and the LX servo bus, chosen by name in the port string.

Like pyserial's URL schemes (and python-can's interface names), the scheme of the port string
picks a module, and each module declares what its transport can do (:class:`Capabilities`):

- a plain device (``/dev/ttyUSB0``, ``COM3``) or ``sim://...``: the raw LX bus (``raw``), every
  LX command, staged moves and broadcast MOVE_START; optionally with GPIO direction control
  (``direction``) for a Raspberry Pi / Jetson UART;
- ``rrc://PATH``: Hiwonder's STM32 "RRC" controller board (``rrc``), 1,000,000 baud;
- ``lobot://PATH`` (its 9600-baud UART) or ``lobot://hid``: the LOBOT Bus Servo Controller
  (``lobot``) of the xArm / LeArm.

``sim://?board=rrc`` and ``sim://?board=lobot`` put an emulated board in front of the emulated
servos; the emulator says which board it is, so the matching transport is chosen by itself.

:func:`connect` opens a port string and returns a :class:`Connection`: the byte port (a pyserial
object, or a HID report port) and, for a board, the :class:`Board` that speaks its protocol.
``ServoBus`` talks raw LX packets on the port when there is no board.
"""

from __future__ import annotations

import errno
import importlib
import urllib.parse
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import serial

from ..errors import PortError, UnsupportedByTransport
from ..protocol import BYTE_TIME_S, Command

RAW_BAUDRATE = 115200
SCHEMES = {"rrc": "rrc", "lobot": "lobot"}  # port-string scheme -> module of this package
INSTEAD_RAW = (
    "connect the servos to the raw LX bus instead (a BusLinker-style USB adapter, or a Pi UART "
    "with --direction)"
)


@dataclass(frozen=True)
class Capabilities:
    """What one transport can do, so callers use what it offers and refuse the rest."""

    transport: str  # what the user has, in words: "RRC board"
    commands: frozenset[Command]  # LX commands it can carry, reads and writes
    staged_start: bool  # MOVE_TIME_WAIT_WRITE + broadcast MOVE_START: every servo starts at once
    stop: str  # how the servos are stopped (Ctrl-C, SIGTERM, SIGHUP, a failed health check)
    load: bool = True  # can torque a servo on without moving it
    move_frame_bytes: int = 0  # a multi-servo move frame: this many bytes + 3 per servo
    host_byte_time_s: float = BYTE_TIME_S  # one byte on the host's link
    forward_s_per_servo: float = 0.0  # a board forwards one servo packet at a time (0: none)

    def supports(self, command: Command) -> bool:
        return Command(command) in self.commands

    def refuse(self, command: Command, port_name: str) -> UnsupportedByTransport:
        return UnsupportedByTransport(
            f"{port_name}: the {self.transport} cannot send {Command(command).name} to a servo; "
            f"{INSTEAD_RAW}"
        )

    def start_skew_s(self, servos: int) -> float:
        """First-to-last start of one tick's moves: 0 with a broadcast START, else the board's
        one-servo-at-a-time forwarding."""
        return 0.0 if self.staged_start else max(servos - 1, 0) * self.forward_s_per_servo


RAW = Capabilities(
    transport="raw LX bus",
    commands=frozenset(Command),
    staged_start=True,
    stop="broadcast MOVE_STOP: every servo holds where it is",
)


class Board(Protocol):
    """A controller board's protocol on a byte port; ``ServoBus`` holds the lock around calls."""

    capabilities: Capabilities

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        """Send an LX write the board can carry; returns the bytes sent."""

    def request(self, command: Command, servo_id: int, timeout_s: float) -> dict[str, int] | None:
        """One attempt at an LX read; its fields, or None when the servo did not answer."""

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        """Move several servos (id, pos_units) over one duration in one frame; bytes sent."""

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        """Stop these servos with the best means the board has."""


@dataclass(frozen=True)
class Connection:
    port: serial.SerialBase  # or any object with the same read/write/flush/close methods
    board: Board | None  # None: raw LX packets on ``port``

    @property
    def capabilities(self) -> Capabilities:
        return self.board.capabilities if self.board is not None else RAW


def connect(port: str | serial.SerialBase, timeout_s: float, direction=None) -> Connection:
    """Open a port string (or adopt an open port) and pick its transport by name."""
    if isinstance(port, str):
        scheme = urllib.parse.urlsplit(port).scheme.lower() if "://" in port else ""
        if scheme in SCHEMES:
            if direction is not None:
                raise PortError(
                    f"{port}: direction control is for the raw bus on a UART; the {scheme} "
                    "board drives its own servo bus"
                )
            module = importlib.import_module(f".{SCHEMES[scheme]}", __name__)
            return module.connect(port, timeout_s)
        port = open_serial(port, timeout_s, RAW_BAUDRATE)
    board_kind = getattr(getattr(port, "emulator", None), "board_kind", None)
    if board_kind is not None:  # an emulated board: it talks its own protocol, not raw LX
        if direction is not None:
            raise PortError(
                f"{getattr(port, 'name', port)}: direction control is for the raw bus on a UART; "
                f"the {board_kind} board drives its own servo bus"
            )
        module = importlib.import_module(f".{board_kind}", __name__)
        return Connection(port, module.board_on(port))
    if direction is not None:
        from .direction import DirectionSerial, direction_lines

        port = DirectionSerial(port, direction_lines(direction))
    return Connection(port, None)


def board_module(port: str | None):
    """The module of the board a port string names (``rrc://``, ``lobot://``, ``sim://?board=``),
    without opening anything; None for the raw bus."""
    if port is None or "://" not in port:
        return None
    parts = urllib.parse.urlsplit(port)
    name = SCHEMES.get(parts.scheme.lower())
    if parts.scheme.lower() == "sim":
        name = SCHEMES.get(urllib.parse.parse_qs(parts.query).get("board", [""])[-1])
    return importlib.import_module(f".{name}", __name__) if name else None


def open_serial(
    url: str, timeout_s: float, baudrate: int, *, quiet_lines: bool = False
) -> serial.SerialBase:
    """A serial port (or pyserial URL, ``sim://`` included) at ``baudrate``, 8N1, exclusive;
    ``quiet_lines``: RTS and DTR held low from the moment it opens."""
    from .. import emulator

    emulator.register_url_handler()
    try:
        port = serial.serial_for_url(
            url,
            baudrate=baudrate,
            bytesize=serial.EIGHTBITS,
            parity=serial.PARITY_NONE,
            stopbits=serial.STOPBITS_ONE,
            timeout=timeout_s,
            exclusive=True,
            do_not_open=True,
        )
        if quiet_lines:
            port.rts = False
            port.dtr = False
        port.open()
        return port
    except (serial.SerialException, ValueError, OSError) as error:
        raise PortError(f"cannot open {url}: {_open_failure(error)}") from error


_LIST_PORTS = "list ports with `choreo ports`; `sim://` is the built-in emulator"


def _open_failure(error: Exception) -> str:
    """Why a port did not open, in the user's terms, with the hint that fits the cause."""
    code = getattr(error, "errno", None)
    if code == errno.ENOENT:
        return f"no such port; {_LIST_PORTS}"
    if code == errno.EACCES:
        return (
            "permission denied; on Linux, join the dialout group (`sudo usermod -aG dialout "
            "$USER`, then log in again)"
        )
    if code in (errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK):
        return "the port is busy. Is another program using it?"
    if "Inappropriate ioctl" in str(error):
        return f"it is not a serial port; {_LIST_PORTS}"
    return f"{error}; {_LIST_PORTS}"


def path_of(url: str) -> str:
    """The device of ``rrc:///dev/ttyAMA0`` (``/dev/ttyAMA0``); ``PortError`` if there is none."""
    rest = url.split("://", 1)[1]
    if not rest:
        raise PortError(f"{url}: name the device after the scheme, as in rrc:///dev/ttyAMA0")
    return rest
