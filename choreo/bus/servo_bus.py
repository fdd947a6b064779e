"""``ServoBus``: one half-duplex LX servo bus behind any pyserial URL.

The only module that sends and receives servo commands; ports are opened by
``choreo.bus.transports``. One lock is held across each request and its reply; earlier writes
are let out and stale input is flushed before every request; each read attempt waits up to its
timeout and is retried a bounded number of times; a reply is accepted only with the expected servo
id, command and length, so echoes (of the request, itself a valid packet, or of earlier writes on a
one-wire bus) and stray bytes are skipped, never taken for the reply. ``sim://`` opens the
built-in emulator.

The port string names the transport (``choreo.bus.transports``): on the raw bus LX packets go out as
they are; through a controller board (``rrc://``, ``lobot://``) each command is carried by the
board's own protocol, and a command the board cannot carry raises ``UnsupportedByTransport``.
``bus.capabilities`` says what the transport can do.

Each command as a typed method (``move``, ``read_info`` ...) is ``typed_commands``, over this
module's ``send`` and ``request``; what a failed read raises is worded by ``read_failure``.
"""

from __future__ import annotations

import contextlib
import enum
import logging
import os
import threading
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import serial

from choreo.bus import transports
from choreo.bus.protocol import (
    BROADCAST_ID,
    SPECS,
    Command,
    CommandSpec,
    check_request,
    check_servo_id,
)
from choreo.bus.read_failure import FailedTries, no_reply_error
from choreo.bus.settings import BUILT_IN_PORT, RETRIES, TIMEOUT_S, BusSettings
from choreo.bus.transports import Connection
from choreo.bus.transports.raw import EchoMode
from choreo.bus.typed_commands import TypedCommands
from choreo.core.arguments import check_member, check_number, check_type, shown
from choreo.errors import BusTimeoutError, OptionError, PortError, ProtocolError

PORT_EXAMPLES = "/dev/ttyUSB0, COM3 or sim://?ids=1-6"  # what a port name looks like

# What a port failing under us raises. pyserial's POSIX port lets termios.error (not an
# OSError) out of flushes on a lost port.
_PORT_LOST: tuple[type[BaseException], ...] = (serial.SerialException, OSError)
try:
    import termios

    _PORT_LOST += (termios.error,)
except ImportError:  # Windows
    pass

log = logging.getLogger(__name__)


class Presence(enum.Enum):
    """Whether a servo answers ID_READ at one ID (``ServoBus.presence``)."""

    ANSWERS = "answers"
    SILENT = "silent"  # nothing came back: no servo has this ID (or it is unpowered)
    GARBLED = "garbled"  # replies failed the checksum: two servos share this ID, or noisy wiring


@dataclass(frozen=True)
class ScanResult:
    """The IDs a scan found answering, and those whose replies came back garbled."""

    found: tuple[int, ...]
    garbled: tuple[int, ...]


class ServoBus(TypedCommands):
    """A servo bus on ``port`` (a port string such as ``/dev/ttyUSB0``, ``sim://?ids=1-6``,
    ``rrc:///dev/ttyAMA0`` or ``lobot://hid``, or an already open serial object). ``direction``:
    GPIO direction control for a raw bus on a Pi/Jetson UART (a preset name such as ``tonypi``,
    or ``rx=4,tx=27``). Use as a context manager so the port is always released."""

    def __init__(
        self,
        port: str | serial.SerialBase | Connection,
        *,
        timeout_s: float = 0.05,
        retries: int = 2,
        echo: EchoMode | str = EchoMode.AUTO,
        direction=None,
    ):
        port = _port_argument(port)
        self.timeout_s = check_number("timeout_s", timeout_s, TIMEOUT_S)
        self.retries = int(check_number("retries", retries, RETRIES))
        echo = check_member("echo", echo, EchoMode)
        self._lock = threading.RLock()
        if isinstance(port, Connection):  # opened already: its backend has its echo mode
            connection = port
        else:
            connection = transports.connect(port, timeout_s, direction, echo)
        self.port, self.backend = connection.port, connection.backend
        self.capabilities = connection.capabilities
        self.clock = connection.clock  # what deadlines on this bus are kept on
        self.emulator = connection.emulator  # an emulated backend's emulator (its wire log)
        named = port if isinstance(port, str) else getattr(self.port, "name", None)
        self.name = named or repr(self.port)

    @classmethod
    def from_settings(
        cls, settings: BusSettings, *, emulated: str | Connection = BUILT_IN_PORT
    ) -> ServoBus:
        """The bus ``settings`` describe (a robot file's ``bus:`` section under the command
        line's options). Where they name no port, ``emulated``: the built-in emulated bus of
        servos 1-6, or an emulator the caller made (a robot's servos, at its home pose)."""
        check_type("settings", settings, BusSettings, "a BusSettings, e.g. BusSettings(port=...)")
        if not isinstance(emulated, (str, Connection)):
            raise OptionError(
                "emulated",
                f"must be a port string such as {BUILT_IN_PORT} or a Connection (e.g. "
                f"choreo.emulator.connection(emulator)), got {shown(emulated)}",
            )
        return cls(
            settings.port if settings.port is not None else emulated,
            timeout_s=settings.timeout_s,
            retries=settings.retries,
            echo=settings.echo,
            direction=settings.direction,
        )

    # --- lifetime ------------------------------------------------------------------------------
    def close(self) -> None:
        with self._lock, self._port_io():
            self.port.close()

    def __enter__(self) -> ServoBus:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def drain(self) -> None:
        """Wait until every byte written so far has left the host."""
        with self._lock, self._port_io():
            self.port.flush()

    def discard_output(self) -> None:
        """Drop bytes written but not yet sent (before an emergency stop)."""
        with self._lock, self._port_io():
            self.port.reset_output_buffer()

    # --- transactions --------------------------------------------------------------------------
    def send(self, command: Command, servo_id: int, /, **fields: int) -> None:
        """Send a write command (no reply exists for writes)."""
        spec = _spec(command)
        if spec.is_read:
            raise OptionError("command", f"{spec.command.name} is a read: use request()")
        if spec.command == Command.ID_WRITE and servo_id == BROADCAST_ID:
            raise OptionError(
                "servo_id",
                f"{BROADCAST_ID}: refusing to broadcast ID_WRITE: it renumbers every servo on the "
                "bus; address the servo by its ID (`choreo servo set-id` finds it when it is alone "
                "on the bus)",
            )
        check_request(spec.command, **fields)  # every field's range: the transport encodes once
        check_servo_id(servo_id)
        self._require(spec.command)
        with self._lock, self._port_io():
            self.backend.send(spec.command, servo_id, fields)

    def request(
        self,
        command: Command,
        servo_id: int,
        /,
        *,
        retries: int | None = None,
        timeout_s: float | None = None,
    ) -> dict[str, int]:
        """Send a read command and return its reply's fields, retrying on silence or garbage."""
        spec = _read_spec(command, servo_id)
        self._require(spec.command)
        attempts = 1 + int(
            self.retries if retries is None else check_number("retries", retries, RETRIES)
        )
        timeout_s = (
            self.timeout_s if timeout_s is None else check_number("timeout_s", timeout_s, TIMEOUT_S)
        )
        with self._lock:
            bad_before = self.backend.bad_checksums
            echo_seen, received = False, b""
            for attempt in range(attempts):
                with self._port_io():
                    result = self.backend.request(spec.command, servo_id, timeout_s)
                if result.fields is not None:
                    return result.fields
                echo_seen |= result.echo_seen
                received = received or result.received
                log.debug(
                    "servo %d: no valid %s reply (try %d/%d)",
                    servo_id,
                    spec.command.name,
                    attempt + 1,
                    attempts,
                )
            garbled = self.backend.bad_checksums - bad_before
        tries = FailedTries(attempts, timeout_s, garbled, echo_seen, received)
        raise no_reply_error(self.name, servo_id, spec.command, tries)

    def _require(self, command: Command) -> None:
        if not self.capabilities.supports(command):
            raise self.capabilities.refuse(command, self.name)

    @contextlib.contextmanager
    def _port_io(self) -> Iterator[None]:
        """Turn the port failing under us (an unplugged USB adapter) into one clear PortError."""
        try:
            yield
        except _PORT_LOST as error:
            raise PortError(
                f"{self.name}: the port was lost ({error}): check the USB cable"
            ) from error

    # --- several servos at once ----------------------------------------------------------------
    def move_many(self, moves: Iterable[tuple[int, int]], time_ms: int) -> int:
        """Move each (servo_id, pos_units) now over one shared ``time_ms``: one frame through a
        board, one MOVE_TIME_WRITE per servo on the raw bus. Returns the bytes sent."""
        moves = list(moves)
        for servo_id, pos_units in moves:  # every range checked before anything is sent
            check_request(Command.MOVE_TIME_WRITE, pos_units=pos_units, time_ms=time_ms)
            check_servo_id(servo_id)
        with self._lock, self._port_io():
            return self.backend.move_many(moves, time_ms)

    def stage_many(self, moves: Iterable[tuple[int, int]], time_ms: int) -> int:
        """MOVE_TIME_WAIT_WRITE to each (servo_id, pos_units) over one shared ``time_ms``, in
        this order and in one write where the link carries that (the raw bus: one system call,
        and behind GPIO direction lines one transmit window); the next MOVE_START runs them
        together. The same packets as ``stage_move`` for each. Returns the bytes sent."""
        writes = [(i, {"pos_units": p, "time_ms": time_ms}) for i, p in moves]
        for servo_id, fields in writes:  # every range checked before anything is sent
            check_request(Command.MOVE_TIME_WAIT_WRITE, **fields)
            check_servo_id(servo_id)
        self._require(Command.MOVE_TIME_WAIT_WRITE)
        with self._lock, self._port_io():
            return self.backend.send_many(Command.MOVE_TIME_WAIT_WRITE, writes)

    def stop_servos(self, servo_ids: Iterable[int]) -> None:
        """Stop these servos by the best means the transport has (``capabilities.stop``): a
        broadcast MOVE_STOP on the raw bus."""
        with self._lock, self._port_io():
            self.backend.stop_many(list(servo_ids))

    # --- several commands ----------------------------------------------------------------------
    def presence(
        self, servo_id: int, *, timeout_s: float | None = None, retries: int = 0
    ) -> Presence:
        """Whether a servo answers ID_READ at ``servo_id``, stays silent, or answers garbled.

        A ``ProtocolError`` that is not about garbled replies (no try saw its echo in DISCARD
        mode) still raises: it is the bus set-up that is wrong, not this ID.
        """
        with self._lock:
            bad_before = self.backend.bad_checksums
            try:
                self.request(Command.ID_READ, servo_id, retries=retries, timeout_s=timeout_s)
            except BusTimeoutError:
                return Presence.SILENT
            except ProtocolError:
                if self.backend.bad_checksums == bad_before:
                    raise
                return Presence.GARBLED
            return Presence.ANSWERS

    def ping(self, servo_id: int, *, timeout_s: float | None = None, retries: int = 0) -> bool:
        """Whether a servo answers ID_READ at ``servo_id``; ``ProtocolError`` if its replies come
        back garbled (two servos sharing the ID), which is not the same as absent."""
        try:
            self.request(Command.ID_READ, servo_id, retries=retries, timeout_s=timeout_s)
        except BusTimeoutError:
            return False
        return True

    def scan_presence(
        self,
        ids: Iterable[int] = range(BROADCAST_ID),
        *,
        timeout_s: float | None = None,
        retries: int = 0,
    ) -> ScanResult:
        """Each ID's ``presence``, in order. Each absent ID costs ``timeout_s`` (the bus's by
        default; USB adapters add up to 16 ms of latency) times ``1 + retries``."""
        if not isinstance(ids, Iterable):
            raise OptionError("ids", f"must be servo IDs (e.g. range(1, 7)), got {shown(ids)}")
        presence = {i: self.presence(i, timeout_s=timeout_s, retries=retries) for i in ids}
        return ScanResult(
            found=tuple(i for i, p in presence.items() if p is Presence.ANSWERS),
            garbled=tuple(i for i, p in presence.items() if p is Presence.GARBLED),
        )

    def scan(
        self,
        ids: Iterable[int] = range(BROADCAST_ID),
        *,
        timeout_s: float | None = None,
        retries: int = 0,
    ) -> list[int]:
        """The IDs that answer, in order (``scan_presence`` also lists garbled ones)."""
        return list(self.scan_presence(ids, timeout_s=timeout_s, retries=retries).found)


def _spec(command: Command | int) -> CommandSpec:
    """The spec of ``command`` (a Command or its number); ``OptionError`` if it is none."""
    try:
        return SPECS[Command(command)]
    except (ValueError, TypeError):
        raise OptionError(
            "command", f"must be a Command (e.g. Command.POS_READ), got {shown(command)}"
        ) from None


def _read_spec(command: Command | int, servo_id: int) -> CommandSpec:
    """The spec of a read of ``command`` from ``servo_id``; ``OptionError`` if it is no read or
    cannot be broadcast."""
    spec = _spec(command)
    if not spec.is_read:
        raise OptionError("command", f"{spec.command.name} has no reply: use send()")
    if servo_id == BROADCAST_ID and spec.command != Command.ID_READ:
        raise OptionError(
            "servo_id",
            f"{BROADCAST_ID}: only ID_READ is answered on broadcast, not {spec.command.name}",
        )
    check_servo_id(servo_id)
    return spec


def _port_argument(port: object) -> str | serial.SerialBase | Connection:
    """``ServoBus``'s port as given, a path as its string; ``OptionError`` if it is no port."""
    if isinstance(port, os.PathLike):
        port = os.fspath(port)
    if isinstance(port, str):
        if not port.strip():
            raise OptionError(
                "port", f"is empty: give a port such as {PORT_EXAMPLES} (`choreo ports` lists them)"
            )
        return port
    # an open port: a pyserial one or anything that reads and writes like it (a test's fake)
    if isinstance(port, Connection) or all(
        callable(getattr(port, name, None)) for name in ("read", "write", "close")
    ):
        return port  # type: ignore[return-value]  # duck-typed: it reads and writes
    raise OptionError(
        "port",
        f"must be a port name such as {PORT_EXAMPLES} (a str or os.PathLike) or an open serial "
        f"port, got {shown(port)}",
    )
