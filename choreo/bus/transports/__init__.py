"""Transports: the backends between the host and the LX servo bus, chosen by name in the port
string.

Like python-can's interfaces (its ``BACKENDS`` table and ``BusABC``) and pyserial's URL handlers,
the scheme of the port string picks a backend, and every backend keeps one contract,
:class:`Transport`: it opens a port string into a :class:`Connection` (the byte port, the
:class:`Backend` speaking on it, the clock) and says, without opening anything, what the host
would speak there (its :class:`Link`: :class:`Capabilities`, the backend, a tick's move frame).
Nothing asks which backend it is:

- a plain device (``/dev/ttyUSB0``, ``COM3``) or a URL pyserial opens itself (``loop://``,
  ``socket://``): the raw LX bus (:mod:`~choreo.bus.transports.raw`), every LX command, staged
  moves and broadcast MOVE_START; optionally with GPIO direction control (``direction``) for a
  Raspberry Pi / Jetson UART;
- ``rrc://PATH``: Hiwonder's STM32 "RRC" controller board (``rrc``), 1,000,000 baud;
- ``lobot://PATH`` (its 9600-baud UART) or ``lobot://hid``: the LOBOT Bus Servo Controller
  (``lobot``) of the xArm;
- any scheme a package adds with an entry point in the ``choreo.backends`` group, naming a module
  or object that keeps the contract. choreo adds its emulator so (``sim://``:
  ``choreo.emulator.backend``): the bus never imports a layer above it.

:func:`connect` opens a port string; :func:`link` tells what it would speak, for a dry run.
"""

from __future__ import annotations

import errno
import functools
import importlib.util
import urllib.parse
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias, runtime_checkable

import serial

from choreo.bus.protocol import BYTE_TIME_S, Command
from choreo.core.clock import Clock
from choreo.core.file_kind import not_a_file
from choreo.errors import PortError, UnsupportedByTransport

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint

    from choreo.bus.transports.direction import DirectionLines, DirectionPins
    from choreo.bus.transports.raw import EchoMode

ENTRY_POINTS = "choreo.backends"  # the entry-point group a package adds a backend in
# What ``direction`` may be: a preset name or "rx=N,tx=N" text, pins, or lines as they are.
Direction: TypeAlias = "str | DirectionPins | DirectionLines"
Echo: TypeAlias = "EchoMode | str"  # how a one-wire bus's echo is treated: raw.EchoMode
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


class BytePort(Protocol):
    """What a backend reads and writes: a pyserial port, or anything with its methods (the LOBOT
    controller's HID reports, GPIO direction control around a UART, a test's fake)."""

    timeout: Any  # seconds a read waits (pyserial: None waits for ever)

    @property
    def in_waiting(self) -> int:
        """Bytes received and not read yet."""

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes) -> int | None: ...

    def flush(self) -> None: ...

    def reset_input_buffer(self) -> None: ...

    def reset_output_buffer(self) -> None: ...

    def close(self) -> None: ...


class Backend(Protocol):
    """What speaks to the servos on a byte port; ``ServoBus`` holds the lock around calls."""

    capabilities: Capabilities

    @property
    def bad_checksums(self) -> int:
        """Replies so far that failed their checksum (two servos answering at once)."""

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        """Send an LX write the transport can carry, its servo ID and fields checked already
        (``ServoBus`` checks, the backend encodes: once); returns the bytes sent."""

    def send_many(self, command: Command, writes: Sequence[tuple[int, dict[str, int]]]) -> int:
        """Send one LX write per (servo_id, fields), checked already, in this order and in one
        write to the port where the link carries that (the raw bus: one system call, and behind
        GPIO direction lines one transmit window); returns the bytes sent."""

    def request(self, command: Command, servo_id: int, timeout_s: float) -> Attempt:
        """One attempt at an LX read."""

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        """Move several servos (id, pos_units, checked already) over one duration now; bytes
        sent."""

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        """Stop these servos with the best means the transport has."""


@dataclass(frozen=True)
class Connection:
    """An open port string: what ``ServoBus`` runs on."""

    port: BytePort
    backend: Backend
    clock: Clock  # what the bus's deadlines are kept on: real time, or an emulator's clock
    emulator: Any = None  # the emulator behind an emulated backend (its wire log), else None

    @property
    def capabilities(self) -> Capabilities:
        return self.backend.capabilities


@dataclass(frozen=True)
class Link:
    """What the host speaks on a byte port: the raw LX bus, or a controller board's frames."""

    capabilities: Capabilities
    backend_on: Callable[[BytePort], Backend]  # the backend speaking it on an open port
    move_frame: Callable[[Sequence[tuple[int, int]], int], bytes]  # a tick's moves, as sent


@runtime_checkable
class Transport(Protocol):
    """What a backend provides, the contract every scheme of a port string keeps: ``raw``,
    ``rrc`` and ``lobot`` are modules that keep it (:data:`BACKENDS`), and so is any module or
    object a package names with an entry point in the ``choreo.backends`` group."""

    def connect(
        self, port: str, timeout_s: float, direction: Direction | None, echo: Echo, /
    ) -> Connection:
        """Open ``port``: the byte port, the backend speaking on it, the clock its deadlines are
        kept on. ``PortError`` (one line) if it cannot be opened as asked (``direction`` through
        a board that drives its own servo bus)."""

    def link(self, port: str, /) -> Link:
        """What the host would speak on ``port``, found without opening anything."""


@runtime_checkable
class OpensItsUrls(Protocol):
    """A backend whose port strings pyserial opens once told where their handler is
    (``sim://``): :func:`open_serial` lets it register the handler first."""

    def register_url_handler(self) -> None: ...


def connect(
    port: str | BytePort,
    timeout_s: float,
    direction: Direction | None = None,
    echo: Echo = "auto",
) -> Connection:
    """Open a port string with the backend its scheme names, or adopt an open port (the raw
    bus)."""
    if not isinstance(port, str):
        return raw.connect(port, timeout_s, direction, echo)
    return transport_for(port).connect(port, timeout_s, direction, echo)


def link(port: str | None) -> Link:
    """What the host would speak on ``port``, without opening anything (None: the built-in
    emulated bus, a raw bus)."""
    return transport_for(port).link(port or "")


def transport_for(port: str | None) -> Transport:
    """The backend the scheme of ``port`` names: bus/'s own (:data:`BACKENDS`), else the one a
    package added under that name (entry point group ``choreo.backends``), else, for a device
    path or a URL pyserial opens itself, the raw bus. ``PortError`` for any other scheme, saying
    which there are."""
    scheme = _scheme(port)
    if not scheme:
        return RAW_BACKEND
    if scheme in BACKENDS:
        return BACKENDS[scheme]
    added = _load_added(scheme, port or "")
    if added is not None:
        return added
    if _pyserial_opens(scheme):
        return RAW_BACKEND
    raise PortError(_no_backend(port or "", scheme))


def refuse_direction(port: str, capabilities: Capabilities) -> PortError:
    return PortError(
        f"{port}: direction control is for the raw bus on a UART; the {capabilities.transport} "
        "drives its own servo bus"
    )


def _scheme(port: str | None) -> str:
    return urllib.parse.urlsplit(port).scheme.lower() if port and "://" in port else ""


@functools.cache
def added_backends() -> dict[str, EntryPoint]:
    """The backends installed packages add, by scheme (their ``choreo.backends`` entry points),
    read once: python-can reads its interfaces' entry points so too."""
    from importlib.metadata import entry_points

    found: dict[str, EntryPoint] = {}
    for entry in entry_points(group=ENTRY_POINTS):
        found.setdefault(entry.name.lower(), entry)  # the first on sys.path, as imports go
    return found


def _load_added(scheme: str, port: str) -> Transport | None:
    entry = added_backends().get(scheme)
    if entry is None:
        return None
    where = f"{entry.value} (package {_package(entry)})"
    try:
        loaded = entry.load()
    except (ImportError, AttributeError) as error:
        raise PortError(
            f"{port}: the {scheme}:// backend {where} cannot be loaded: {error}"
        ) from error
    if not isinstance(loaded, Transport):
        raise PortError(
            f"{port}: the {scheme}:// backend {where} does not keep choreo's contract: it "
            "provides no connect() and link() (choreo.bus.transports.Transport)"
        )
    return loaded


def _package(entry: EntryPoint) -> str:
    return entry.dist.name if entry.dist is not None else "unknown"


def _pyserial_opens(scheme: str) -> bool:
    """Whether pyserial has a URL handler for ``scheme`` (``loop``, ``socket``, ``rfc2217``...)."""
    for package in serial.protocol_handler_packages:
        try:
            if importlib.util.find_spec(f"{package}.protocol_{scheme}") is not None:
                return True
        except (ImportError, ValueError):  # a handler package that is gone, a scheme no name
            continue
    return False


# Schemes choreo itself adds through an entry point: the package to reinstall if one is missing.
ADDED_BY_CHOREO = {"sim": "choreo (its emulator)"}


def _no_backend(port: str, scheme: str) -> str:
    """One line: the scheme has no backend, which ones there are, what adds the missing one."""
    added = ", ".join(f"{n}:// ({_package(e)})" for n, e in sorted(added_backends().items()))
    known = ", ".join(f"{n}://" for n in BACKENDS) + (f", {added}" if added else "")
    if scheme in ADDED_BY_CHOREO:
        fix = (
            f"{scheme}:// comes with {ADDED_BY_CHOREO[scheme]} through its entry points, which "
            "this Python does not see: reinstall choreo (in a checkout: pip install -e .)"
        )
    else:
        fix = f"a package adds one with an entry point in the {ENTRY_POINTS} group"
    return (
        f"{port}: no backend for {scheme}://; there are {known}, a device path and the URLs "
        f"pyserial opens (loop://, socket://, rfc2217://); {fix}"
    )


def open_serial(
    url: str, timeout_s: float, baudrate: int, *, quiet_lines: bool = False
) -> serial.SerialBase:
    """A serial port (or pyserial URL, ``sim://`` included) at ``baudrate``, 8N1, exclusive;
    ``quiet_lines``: RTS and DTR held low from the moment it opens."""
    _let_pyserial_open(url)
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
    except KeyError as error:  # pyserial 3.5's loop:// formats its refusal of an option wrongly
        raise PortError(
            f"cannot open {url}: pyserial does not take the options after '?' for this scheme"
        ) from error


def _let_pyserial_open(url: str) -> None:
    """A backend a package added may have pyserial open its URLs: it registers its handler."""
    scheme = _scheme(url)
    added = _load_added(scheme, url) if scheme and scheme not in BACKENDS else None
    if isinstance(added, OpensItsUrls):
        added.register_url_handler()


_LIST_PORTS = "list ports with `choreo ports`; `sim://` is the built-in emulator"


def _open_failure(url: str, error: Exception) -> str:
    """Why a port did not open, in the user's terms, with the hint that fits the cause."""
    if isinstance(error.__cause__, ValueError):  # the URL's own settings (sim://?start_gap_ms=-1)
        return str(error.__cause__)
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


# bus/'s own backends, by the scheme of the port string. They import the contract above, so they
# are imported after it.
from choreo.bus.transports import lobot, raw, rrc  # noqa: E402

BACKENDS: dict[str, Transport] = {"rrc": rrc, "lobot": lobot}
RAW_BACKEND: Transport = raw  # a device path, or a URL pyserial opens itself
