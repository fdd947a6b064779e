"""Transports: the backends between the host and the LX servo bus, chosen by name in the port
string.

Like python-can's interfaces (its ``BACKENDS`` table and ``BusABC``) and pyserial's URL schemes,
the scheme of the port string picks a module from :data:`BACKENDS`, and every backend is an
ordinary implementation of :class:`Backend` that declares what it can do
(:class:`Capabilities`); nothing asks which backend it is:

- a plain device (``/dev/ttyUSB0``, ``COM3``) or another pyserial URL: the raw LX bus
  (:mod:`~choreo.bus.transports.raw`), every LX command, staged moves and broadcast MOVE_START;
  optionally with GPIO direction control (``direction``) for a Raspberry Pi / Jetson UART;
- ``rrc://PATH``: Hiwonder's STM32 "RRC" controller board (``rrc``), 1,000,000 baud;
- ``lobot://PATH`` (its 9600-baud UART) or ``lobot://hid``: the LOBOT Bus Servo Controller
  (``lobot``) of the xArm;
- ``sim://...``: the built-in emulator (``choreo.emulator.backend``), the raw bus or, with
  ``board=rrc|lobot``, that board in front of the emulated servos; its clock is the emulator's.

:func:`connect` opens a port string and returns a :class:`Connection`: the byte port, the
backend that speaks on it, and the clock the bus runs on.
"""

from __future__ import annotations

import errno
import importlib
import urllib.parse
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Protocol

import serial

from choreo.bus.protocol import BYTE_TIME_S, Command
from choreo.core.clock import Clock
from choreo.core.file_kind import not_a_file
from choreo.errors import PortError, UnsupportedByTransport

# port-string scheme -> the module that opens it; any other scheme is a pyserial URL on the raw bus
BACKENDS = {
    "rrc": "choreo.bus.transports.rrc",
    "lobot": "choreo.bus.transports.lobot",
    "sim": "choreo.emulator.backend",
}
RAW_BACKEND = "choreo.bus.transports.raw"
INSTEAD_RAW = (
    "connect the servos to the raw LX bus instead (a BusLinker-style USB adapter, or a Pi UART "
    "with its GPIO direction lines, {option})"
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
        return UnsupportedByTransport.naming(
            "direction",
            f"{port_name}: the {self.transport} cannot send {Command(command).name} to a servo; "
            + INSTEAD_RAW,
            command=Command(command),
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


@dataclass(frozen=True)
class Attempt:
    """One read attempt and what came back: the reply's fields (None: no valid reply in time),
    whether the echo of the request was seen (always True where no echo is expected), the bytes
    received (for an error message)."""

    fields: dict[str, int] | None
    echo_seen: bool = True
    received: bytes = b""


class Backend(Protocol):
    """What speaks to the servos on a byte port; ``ServoBus`` holds the lock around calls."""

    capabilities: Capabilities

    @property
    def bad_checksums(self) -> int:
        """Replies so far that failed their checksum (two servos answering at once)."""

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        """Send an LX write the transport can carry, its servo ID and fields checked already
        (``ServoBus`` checks, the backend encodes: once); returns the bytes sent."""

    def request(self, command: Command, servo_id: int, timeout_s: float) -> Attempt:
        """One attempt at an LX read."""

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        """Move several servos (id, pos_units, checked already) over one duration now; bytes
        sent."""

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        """Stop these servos with the best means the transport has."""


@dataclass(frozen=True)
class Connection:
    port: Any  # a pyserial port, or any object with its read/write/flush/close methods
    backend: Backend
    clock: Clock  # what the bus's deadlines are kept on: real time, or an emulator's clock
    emulator: Any = None  # the emulator behind an emulated backend (its wire log), else None

    @property
    def capabilities(self) -> Capabilities:
        return self.backend.capabilities


def connect(port: str | serial.SerialBase, timeout_s: float, direction=None, echo="auto"):
    """Open a port string (or adopt an open port: the raw bus) with the backend its scheme
    names."""
    module = importlib.import_module(_module_name(port if isinstance(port, str) else None))
    return module.connect(port, timeout_s, direction, echo)


def refuse_direction(port: str, capabilities: Capabilities) -> PortError:
    return PortError(
        f"{port}: direction control is for the raw bus on a UART; the {capabilities.transport} "
        "drives its own servo bus"
    )


def backend_module(port: str | None) -> ModuleType:
    """The module of the backend a port string names, without opening anything: for ``sim://``,
    the module of what the host talks to (the raw bus, or the board named by ``board=``)."""
    module = importlib.import_module(_module_name(port))
    host_module = getattr(module, "host_module", None)
    return host_module(port) if host_module is not None else module


def _register_url_handler(url: str) -> None:
    """Let pyserial open the URL schemes a backend provides itself (``sim://``)."""
    register = getattr(importlib.import_module(_module_name(url)), "register_url_handler", None)
    if register is not None:
        register()


def _module_name(port: str | None) -> str:
    scheme = urllib.parse.urlsplit(port).scheme.lower() if port and "://" in port else ""
    return BACKENDS.get(scheme, RAW_BACKEND)


def open_serial(
    url: str, timeout_s: float, baudrate: int, *, quiet_lines: bool = False
) -> serial.SerialBase:
    """A serial port (or pyserial URL, ``sim://`` included) at ``baudrate``, 8N1, exclusive;
    ``quiet_lines``: RTS and DTR held low from the moment it opens."""
    _register_url_handler(url)
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
        raise PortError(f"cannot open {url}: {_open_failure(url, error)}") from error


_LIST_PORTS = "list ports with `choreo ports`; `sim://` is the built-in emulator"


def _open_failure(url: str, error: Exception) -> str:
    """Why a port did not open, in the user's terms, with the hint that fits the cause."""
    kind = not_a_file(url) if "://" not in url else None
    if kind not in (None, "a device"):
        return f"it is {kind}, not a serial port; {_LIST_PORTS}"
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
