"""The raw LX bus: LX packets written as they are on a serial port (a BusLinker-style USB
adapter, a Pi / Jetson UART with GPIO direction lines, any pyserial URL).

Every LX command, staged moves and a broadcast MOVE_START. Reads skip whatever is not their
reply: on a one-wire bus the echoes of earlier writes and of the request itself come back first
(:class:`EchoMode` says how to treat them), and stray bytes or other packets may sit in between.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Sequence

from choreo.bus.protocol import (
    BROADCAST_ID,
    SPECS,
    Command,
    Packet,
    PacketDecoder,
    decode_reply,
    encode_checked,
    encode_request,
)
from choreo.bus.transports import (
    RAW,
    Attempt,
    BytePort,
    Capabilities,
    Connection,
    Direction,
    Link,
    open_serial,
)
from choreo.core.clock import Clock, RealClock

log = logging.getLogger(__name__)

BAUDRATE = 115200
CAPABILITIES = RAW
ECHO_REPORT_BYTES = 16  # how much of what came back instead of an echo an error shows


class EchoMode(enum.Enum):
    NONE = "none"  # the adapter does not echo (vendor BusLinker, Raspberry Pi HATs)
    DISCARD = "discard"  # one-wire wiring: a reply counts only after the request's own echo
    AUTO = "auto"  # skip echoes if they show up
    # In every mode, echoes of earlier writes and stray bytes before a reply are skipped.


def connect(
    port: str | BytePort,
    timeout_s: float,
    direction: Direction | None = None,
    echo: EchoMode | str = EchoMode.AUTO,
    clock: Clock | None = None,
) -> Connection:
    """The raw bus on a device path or pyserial URL (or a port opened already), optionally
    behind GPIO direction lines; ``clock``: what the port's timeouts run on (real time, unless
    the port is an emulator's)."""
    opened_here = isinstance(port, str)
    wired: BytePort = open_serial(port, timeout_s, BAUDRATE) if isinstance(port, str) else port
    if direction is not None:
        from choreo.bus.transports.direction import DirectionSerial, direction_lines

        try:
            lines = direction_lines(direction)
        except BaseException:
            if opened_here:  # a preset this computer cannot resolve, or no gpiod
                wired.close()
            raise
        wired = DirectionSerial(wired, lines)
    clock = clock or RealClock()
    return Connection(wired, RawBus(wired, EchoMode(echo), clock), clock)


def move_frame(moves: Sequence[tuple[int, int]], time_ms: int) -> bytes:
    """Several servos (id, pos_units) moved now over one duration: a MOVE_TIME_WRITE each, the
    values checked already."""
    return b"".join(
        encode_checked(Command.MOVE_TIME_WRITE, i, {"pos_units": p, "time_ms": time_ms})
        for i, p in moves
    )


def link(port: str) -> Link:
    """LX packets as they are, whatever the device or pyserial URL."""
    return LINK


class RawBus:
    """LX packets on a byte port; ``ServoBus`` holds the lock around every call."""

    capabilities: Capabilities = CAPABILITIES

    def __init__(self, port: BytePort, echo: EchoMode = EchoMode.AUTO, clock: Clock | None = None):
        self.port = port
        self.echo = echo
        self.clock = clock or RealClock()  # a read's deadline, on the clock the port runs on
        self.decoder = PacketDecoder()

    @property
    def bad_checksums(self) -> int:
        return self.decoder.bad_checksums

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        return self._write(encode_checked(command, servo_id, fields))

    def send_many(self, command: Command, writes: Sequence[tuple[int, dict[str, int]]]) -> int:
        return self._write(b"".join(encode_checked(command, i, fields) for i, fields in writes))

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        return self._write(move_frame(moves, time_ms))

    def _write(self, packets: bytes) -> int:
        """Packets in one write: one system call, and behind GPIO direction lines one transmit
        window (the line turns around once, after the last). Their echoes, if any, are skipped
        by the next request."""
        self.port.write(packets)
        return len(packets)

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        """One broadcast MOVE_STOP stops every servo at once, whichever are named."""
        self.port.write(encode_request(Command.MOVE_STOP, BROADCAST_ID))

    def request(self, command: Command, servo_id: int, timeout_s: float) -> Attempt:
        """One attempt: let earlier writes leave, flush, write, then read until the expected reply
        or until ``timeout_s`` has passed.

        Whatever else arrives meanwhile (the echoes of earlier writes and of this request on a
        one-wire bus, stray bytes, other packets) is skipped, so a read after any number of
        writes works in every echo mode. Only a read that came back short ends the attempt
        early, and pyserial returns short only once its timeout has passed.
        """
        port, packet = self.port, encode_request(command, servo_id)
        port.flush()  # earlier writes (and so their echoes) are on the wire before the flush
        port.reset_input_buffer()
        self.decoder.reset()
        port.write(packet)
        deadline_s = self.clock.now() + timeout_s
        reply_len = SPECS[command].read_reply_len + 3
        echo_seen = self.echo is not EchoMode.DISCARD  # DISCARD: a reply only after our echo
        wanted, wait_s, overdue = reply_len, timeout_s, False
        received = bytearray()
        while True:
            port.timeout = wait_s
            data = port.read(wanted)
            received += data[: ECHO_REPORT_BYTES - len(received)]  # for an error message
            for reply in self.decoder.feed(data):
                if reply.encode() == packet:
                    echo_seen = True  # the echo of our own request
                elif echo_seen and _is_reply(reply, command, servo_id):
                    return Attempt(decode_reply(command, reply), echo_seen, bytes(received))
            if len(data) < wanted or overdue:
                break  # the port waited out the rest of the timeout
            wait_s = deadline_s - self.clock.now()
            if wait_s > 0:
                # Ask only for the rest of the frame begun: asking for a whole reply again after
                # an echo or a stray packet would wait for bytes that never come.
                wanted = self.decoder.bytes_to_complete(reply_len)
            else:  # the host ran late (descheduled): look at what has arrived, without waiting
                overdue, wait_s, wanted = True, 0, max(port.in_waiting, 1)
        return Attempt(None, echo_seen, bytes(received))


LINK = Link(CAPABILITIES, RawBus, move_frame)


def _is_reply(reply: Packet, command: Command, servo_id: int) -> bool:
    expected_len = SPECS[command].reply_len
    is_match = (
        reply.command == command
        and len(reply.params) + 3 == expected_len
        and (servo_id == BROADCAST_ID or reply.servo_id == servo_id)
    )
    if not is_match:
        log.debug("skipping unexpected packet %s", reply)
    return is_match
