"""``rrc://PATH``: Hiwonder's STM32 "RRC" controller board (newer TonyPi, SpiderPi, PuppyPi,
JetArm), on its 1,000,000-baud UART or USB-CDC link.

Frames are ``AA 55 FUNC LEN DATA CRC``: LEN counts DATA, CRC is CRC-8/MAXIM over FUNC, LEN and
DATA, multi-byte fields little-endian. Bus servos are FUNC 5; DATA[0] is a sub-command that the
board turns into LX packets on its own 115200-baud servo bus, one servo at a time. Reads are
answered ``id sub status value``: status 0 is good, -1 (FF) means the servo did not answer within
the board's 5 ms (value bytes zero). The board also sends frames nobody asked for (battery about
once a second, IMU, keys): they are told apart by FUNC, and a reply must match the request's id
and sub-command (a late reply to an earlier request is skipped). See docs/transports.md.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

from choreo.bus.framing import MORE, NOT_A_FRAME, ResyncDecoder
from choreo.bus.protocol import SPECS, Command, pack_fields, unpack_fields
from choreo.bus.transports import (
    Attempt,
    BytePort,
    Capabilities,
    Connection,
    Direction,
    Link,
    open_serial,
    path_of,
    refuse_direction,
)
from choreo.core.clock import RealClock

log = logging.getLogger(__name__)

BAUDRATE = 1_000_000
HEADER = b"\xaa\x55"
MAX_FUNC = 11  # FUNC 0-11 exist; the board's parser resynchronises on anything higher
FUNC_SYS, FUNC_BUS_SERVO = 0, 5
SYS_BATTERY = 0x04
MOVE, STOP, UNLOAD, LOAD = 0x01, 0x03, 0x0B, 0x0C
LX_PACKET_S = 10 * 10 / 115200  # the board sends a 10-byte LX packet and waits for it to leave
MAX_READS_PER_ATTEMPT = 4

# LX write -> sub-command; DATA is sub, id, then the LX parameters in the LX layout.
WRITE_SUBS = {
    Command.ID_WRITE: 0x10,
    Command.ANGLE_OFFSET_ADJUST: 0x20,
    Command.ANGLE_OFFSET_WRITE: 0x24,
    Command.ANGLE_LIMIT_WRITE: 0x30,
    Command.VIN_LIMIT_WRITE: 0x34,
    Command.TEMP_MAX_LIMIT_WRITE: 0x38,
}
# LX read -> sub-command; the reply's value bytes are the LX reply's parameters.
READ_SUBS = {
    Command.POS_READ: 0x05,
    Command.VIN_READ: 0x07,
    Command.TEMP_READ: 0x09,
    Command.LOAD_OR_UNLOAD_READ: 0x0D,
    Command.ID_READ: 0x12,
    Command.ANGLE_OFFSET_READ: 0x22,
    Command.ANGLE_LIMIT_READ: 0x32,
    Command.VIN_LIMIT_READ: 0x36,
    Command.TEMP_MAX_LIMIT_READ: 0x3A,
}

CAPABILITIES = Capabilities(
    transport="RRC board",
    commands=frozenset(
        {Command.MOVE_TIME_WRITE, Command.MOVE_STOP, Command.LOAD_OR_UNLOAD_WRITE}
        | WRITE_SUBS.keys()
        | READ_SUBS.keys()
    ),
    staged_start=False,
    stop="one MOVE_STOP frame (sub-command 03) listing the robot's servos; the board stops them "
    "one after another, about 0.87 ms apart",
    host_byte_time_s=10 / BAUDRATE,
    move_frame_bytes=9,
    forward_s_per_servo=LX_PACKET_S,
)


def crc8(data: bytes | bytearray) -> int:
    """CRC-8/MAXIM (Dallas): reflected polynomial 0x8C, init 0, no final XOR."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8C if crc & 1 else crc >> 1
    return crc


def encode_frame(func: int, data: bytes) -> bytes:
    if not 0 <= func <= MAX_FUNC or len(data) > 255:
        raise ValueError(f"FUNC must be 0-{MAX_FUNC} and DATA at most 255 bytes")
    body = bytes((func, len(data))) + data
    return HEADER + body + bytes((crc8(body),))


@dataclass(frozen=True)
class Frame:
    func: int
    data: bytes


class FrameDecoder(ResyncDecoder[Frame]):
    """Bytes to frames; resynchronises on ``AA 55`` and drops frames failing the CRC
    (``bad_checksums`` counts them). Never raises."""

    header = HEADER

    def frame_length(self, buf: bytearray) -> int:
        if len(buf) >= 3 and buf[2] > MAX_FUNC:
            return NOT_A_FRAME
        return 5 + buf[3] if len(buf) >= 4 else MORE

    def intact(self, buf: bytearray, total: int) -> bool:
        return crc8(buf[2 : total - 1]) == buf[total - 1]

    def frame(self, buf: bytearray, total: int) -> Frame:
        return Frame(buf[2], bytes(buf[4 : total - 1]))


# --- host -> board packets ---------------------------------------------------------------------
def move_frame(moves: Sequence[tuple[int, int]], time_ms: int) -> bytes:
    data = bytes((MOVE,)) + time_ms.to_bytes(2, "little") + bytes((len(moves),))
    for servo_id, pos_units in moves:
        data += bytes((servo_id,)) + pos_units.to_bytes(2, "little")
    return encode_frame(FUNC_BUS_SERVO, data)


def stop_frame(servo_ids: Sequence[int]) -> bytes:
    return encode_frame(FUNC_BUS_SERVO, bytes((STOP, len(servo_ids), *servo_ids)))


def write_frame(command: Command, servo_id: int, fields: dict[str, int]) -> bytes:
    """The frame for an LX write (``KeyError`` if the board has none)."""
    command = Command(command)
    if command == Command.MOVE_TIME_WRITE:
        return move_frame([(servo_id, fields["pos_units"])], fields["time_ms"])
    if command == Command.MOVE_STOP:
        return stop_frame([servo_id])
    if command == Command.LOAD_OR_UNLOAD_WRITE:
        # 0B unloads and 0C loads, whatever the vendor SDK's parameter is called
        sub = LOAD if fields["loaded"] else UNLOAD
        return encode_frame(FUNC_BUS_SERVO, bytes((sub, servo_id)))
    params = pack_fields(SPECS[command].request, fields)
    return encode_frame(FUNC_BUS_SERVO, bytes((WRITE_SUBS[command], servo_id)) + params)


def read_frame(command: Command, servo_id: int) -> bytes:
    return encode_frame(FUNC_BUS_SERVO, bytes((READ_SUBS[Command(command)], servo_id)))


def reply_total(command: Command) -> int:
    """Bytes of the whole reply frame to a read: header, FUNC, LEN, id sub status value, CRC."""
    return 5 + SPECS[Command(command)].read_reply_len


def battery_mv(frame: Frame) -> int | None:
    if frame.func == FUNC_SYS and len(frame.data) == 3 and frame.data[0] == SYS_BATTERY:
        return int.from_bytes(frame.data[1:3], "little")
    return None


# --- the board ---------------------------------------------------------------------------------
def connect(
    url: str, timeout_s: float, direction: Direction | None = None, echo: object = None
) -> Connection:
    """The board on the device ``rrc://PATH`` names (its link has no echo: ``echo`` is moot)."""
    if direction is not None:
        raise refuse_direction(url, CAPABILITIES)
    # The vendor SDK keeps RTS and DTR low when it opens the board's port.
    port = open_serial(path_of(url), timeout_s, BAUDRATE, quiet_lines=True)
    return Connection(port, board_on(port), RealClock())


def link(url: str) -> Link:
    """The board's frames, on whichever link ``rrc://PATH`` names."""
    return LINK


def board_on(port: BytePort) -> RrcBoard:
    return RrcBoard(port)


class RrcBoard:
    """The RRC board's bus-servo sub-commands on an open port."""

    capabilities = CAPABILITIES

    def __init__(self, port: BytePort):
        self.port = port
        self.decoder = FrameDecoder()
        self.battery_mv: int | None = None  # from the board's unsolicited battery frames
        self.bad_checksums = 0  # the board checks the servos' replies itself

    def send(self, command: Command, servo_id: int, fields: dict[str, int]) -> int:
        return self.send_many(command, [(servo_id, fields)])

    def send_many(self, command: Command, writes: Sequence[tuple[int, dict[str, int]]]) -> int:
        frames = b"".join(write_frame(command, servo_id, fields) for servo_id, fields in writes)
        self.port.write(frames)  # the board parses its frames one after another
        return len(frames)

    def move_many(self, moves: Sequence[tuple[int, int]], time_ms: int) -> int:
        frame = move_frame(moves, time_ms)
        self.port.write(frame)
        return len(frame)

    def stop_many(self, servo_ids: Sequence[int]) -> None:
        self.port.write(stop_frame(servo_ids))

    def request(self, command: Command, servo_id: int, timeout_s: float) -> Attempt:
        return Attempt(self._read(command, servo_id, timeout_s))

    def _read(self, command: Command, servo_id: int, timeout_s: float) -> dict[str, int] | None:
        sub, port = READ_SUBS[Command(command)], self.port
        port.timeout = timeout_s
        port.flush()  # a move frame may still be leaving: the timeout starts after it
        port.reset_input_buffer()  # stale replies and unsolicited frames: not ours
        self.decoder.reset()
        port.write(read_frame(command, servo_id))
        wanted = total = reply_total(command)
        for _ in range(MAX_READS_PER_ATTEMPT):
            data = port.read(wanted)
            for frame in self.decoder.feed(data):
                fields = self._answer(frame, command, sub, servo_id)
                if fields is not None:
                    return fields or None  # {}: the board says the servo did not answer
            if len(data) < wanted:
                return None
            wanted = self.decoder.bytes_to_complete(total)
        return None

    def _answer(self, frame: Frame, command: Command, sub: int, servo_id: int):
        """The reply's fields; {} for status FF; None when the frame is not our reply."""
        if (mv := battery_mv(frame)) is not None:
            self.battery_mv = mv
            return None
        data = frame.data
        if frame.func != FUNC_BUS_SERVO or len(data) < 3 or data[0] != servo_id or data[1] != sub:
            log.debug("skipping a frame that is not the reply: FUNC %d %s", frame.func, data.hex())
            return None
        if data[2] != 0:
            return {}
        reply = SPECS[Command(command)].reply
        if reply is None or len(data) != reply_total(command) - 5:
            return None
        return unpack_fields(reply, data[3:])


LINK = Link(CAPABILITIES, board_on, move_frame)
