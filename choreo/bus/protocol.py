"""The LX bus-servo protocol as data: command table, encoding, checksum, stream decoder.

Pure: no I/O. ``docs/protocol.md`` is the reference (the vendor document's mistakes are
corrected there). A packet is ``55 55 ID LEN CMD P1..Pn CHK`` with ``LEN = n + 3`` and
``CHK = ~(ID + LEN + CMD + P1 + ... + Pn) & 0xFF``; multi-byte values are little-endian.

Requests are built with :func:`encode_request`, which checks every argument against its field's
valid range and raises ``ValueError`` naming the field; nothing is clamped (:func:`check_request`
is that check alone, for values a user confirms before they are sent, and :func:`encode_checked`
the encoding alone, for values checked already). Replies are parsed with
:func:`decode_reply`, which does not range-check (a servo may report -12 or 1130 as its position).
"""

from __future__ import annotations

import enum
import functools
import struct
from dataclasses import dataclass, field

from choreo.bus.framing import MORE, NOT_A_FRAME, ResyncDecoder
from choreo.bus.servo_models import POSITION_RANGE_UNITS
from choreo.core.arguments import shown
from choreo.errors import OptionError

HEADER = b"\x55\x55"
BROADCAST_ID = 0xFE
MAX_SERVO_ID = 253
MIN_LEN = 3  # LEN of a packet without parameters
MAX_LEN = 7  # the longest packet of this protocol has 4 parameter bytes
BYTE_TIME_S = 10 / 115200  # one byte on the wire: start + 8 data + stop bits


class Command(enum.IntEnum):
    MOVE_TIME_WRITE = 1
    MOVE_TIME_READ = 2
    MOVE_TIME_WAIT_WRITE = 7
    MOVE_TIME_WAIT_READ = 8
    MOVE_START = 11
    MOVE_STOP = 12
    ID_WRITE = 13
    ID_READ = 14
    ANGLE_OFFSET_ADJUST = 17
    ANGLE_OFFSET_WRITE = 18
    ANGLE_OFFSET_READ = 19
    ANGLE_LIMIT_WRITE = 20
    ANGLE_LIMIT_READ = 21
    VIN_LIMIT_WRITE = 22
    VIN_LIMIT_READ = 23
    TEMP_MAX_LIMIT_WRITE = 24
    TEMP_MAX_LIMIT_READ = 25
    TEMP_READ = 26
    VIN_READ = 27
    POS_READ = 28
    OR_MOTOR_MODE_WRITE = 29
    OR_MOTOR_MODE_READ = 30
    LOAD_OR_UNLOAD_WRITE = 31
    LOAD_OR_UNLOAD_READ = 32
    LED_CTRL_WRITE = 33
    LED_CTRL_READ = 34
    LED_ERROR_WRITE = 35
    LED_ERROR_READ = 36
    DIS_READ = 48


class ErrorMask(enum.IntFlag):
    """LED_ERROR bits: which faults make the LED flash."""

    NONE = 0
    OVER_TEMPERATURE = 1
    VOLTAGE = 2
    STALLED = 4


@dataclass(frozen=True)
class Field:
    name: str
    fmt: str  # a struct code: B b H h I
    lo: int
    hi: int

    @property
    def size(self) -> int:
        return struct.calcsize("<" + self.fmt)


def _u8(name: str, lo: int = 0, hi: int = 0xFF) -> Field:
    return Field(name, "B", lo, hi)


def _u16(name: str, lo: int = 0, hi: int = 0xFFFF) -> Field:
    return Field(name, "H", lo, hi)


_POS = _u16("pos_units", *POSITION_RANGE_UNITS)
_TIME = _u16("time_ms", 0, 30000)
_MOVE = (_POS, _TIME)


@dataclass(frozen=True)
class CommandSpec:
    command: Command
    request: tuple[Field, ...] = ()
    reply: tuple[Field, ...] | None = None  # None: never answered
    ordered_pair: tuple[str, str] | None = (
        None  # (min field, max field) that must satisfy min < max
    )

    # worked out once: every request and reply on the bus asks (identify: ~500 a second)
    @functools.cached_property
    def request_len(self) -> int:
        return MIN_LEN + sum(f.size for f in self.request)

    @functools.cached_property
    def reply_len(self) -> int | None:
        return None if self.reply is None else MIN_LEN + sum(f.size for f in self.reply)

    @property
    def read_reply_len(self) -> int:
        """``reply_len`` of a command known to be answered (a read); a write has none."""
        if self.reply_len is None:
            raise ValueError(f"{self.command.name} is never answered")
        return self.reply_len

    @property
    def is_read(self) -> bool:
        return self.reply is not None


C = Command
SPECS: dict[Command, CommandSpec] = {
    s.command: s
    for s in (
        CommandSpec(C.MOVE_TIME_WRITE, _MOVE),
        CommandSpec(C.MOVE_TIME_READ, reply=(_u16("pos_units"), _u16("time_ms"))),
        CommandSpec(C.MOVE_TIME_WAIT_WRITE, _MOVE),
        CommandSpec(C.MOVE_TIME_WAIT_READ, reply=(_u16("pos_units"), _u16("time_ms"))),
        CommandSpec(C.MOVE_START),
        CommandSpec(C.MOVE_STOP),
        CommandSpec(C.ID_WRITE, (_u8("new_id", 0, MAX_SERVO_ID),)),
        CommandSpec(C.ID_READ, reply=(_u8("servo_id"),)),
        CommandSpec(C.ANGLE_OFFSET_ADJUST, (Field("offset_units", "b", -125, 125),)),
        CommandSpec(C.ANGLE_OFFSET_WRITE),
        CommandSpec(C.ANGLE_OFFSET_READ, reply=(Field("offset_units", "b", -128, 127),)),
        CommandSpec(
            C.ANGLE_LIMIT_WRITE,
            (_u16("min_units", *POSITION_RANGE_UNITS), _u16("max_units", *POSITION_RANGE_UNITS)),
            ordered_pair=("min_units", "max_units"),
        ),
        CommandSpec(C.ANGLE_LIMIT_READ, reply=(_u16("min_units"), _u16("max_units"))),
        CommandSpec(
            C.VIN_LIMIT_WRITE,
            (_u16("min_mv", 4500, 14000), _u16("max_mv", 4500, 14000)),
            ordered_pair=("min_mv", "max_mv"),
        ),
        CommandSpec(C.VIN_LIMIT_READ, reply=(_u16("min_mv"), _u16("max_mv"))),
        CommandSpec(C.TEMP_MAX_LIMIT_WRITE, (_u8("temp_c", 50, 100),)),
        CommandSpec(C.TEMP_MAX_LIMIT_READ, reply=(_u8("temp_c"),)),
        CommandSpec(C.TEMP_READ, reply=(_u8("temp_c"),)),
        CommandSpec(C.VIN_READ, reply=(_u16("vin_mv"),)),
        CommandSpec(C.POS_READ, reply=(Field("pos_units", "h", -32768, 32767),)),
        CommandSpec(
            C.OR_MOTOR_MODE_WRITE,
            (_u8("mode", 0, 1), _u8("reserved", 0, 0), Field("speed", "h", -1000, 1000)),
        ),
        CommandSpec(
            C.OR_MOTOR_MODE_READ,
            reply=(_u8("mode"), _u8("reserved"), Field("speed", "h", -32768, 32767)),
        ),
        CommandSpec(C.LOAD_OR_UNLOAD_WRITE, (_u8("loaded", 0, 1),)),
        CommandSpec(C.LOAD_OR_UNLOAD_READ, reply=(_u8("loaded"),)),
        CommandSpec(C.LED_CTRL_WRITE, (_u8("led_off", 0, 1),)),
        CommandSpec(C.LED_CTRL_READ, reply=(_u8("led_off"),)),
        CommandSpec(C.LED_ERROR_WRITE, (_u8("mask", 0, 7),)),
        CommandSpec(C.LED_ERROR_READ, reply=(_u8("mask"),)),
        CommandSpec(C.DIS_READ, reply=(Field("distance", "I", 0, 0xFFFFFFFF),)),
    )
}
del C


@dataclass(frozen=True)
class Packet:
    """One packet with a valid frame and checksum (request or reply; the bytes don't say which)."""

    servo_id: int
    command: int  # usually a Command; unknown numbers are kept as plain ints
    params: bytes = field(default=b"")

    def encode(self) -> bytes:
        return encode_packet(self.servo_id, self.command, self.params)


def checksum(body: bytes | bytearray) -> int:
    """``~(ID + LEN + CMD + params) & 0xFF`` over ``body`` = ID LEN CMD params."""
    return ~sum(body) & 0xFF


def encode_packet(servo_id: int, command: int, params: bytes = b"") -> bytes:
    """Frame raw parameters; checks only what makes a packet valid at all."""
    check_servo_id(servo_id)
    if len(params) > MAX_LEN - MIN_LEN:
        raise ValueError(f"params must be at most {MAX_LEN - MIN_LEN} bytes, got {len(params)}")
    body = bytes((servo_id, len(params) + MIN_LEN, command)) + params
    return HEADER + body + bytes((checksum(body),))


def _check_range(name: str, value: int, lo: int, hi: int) -> None:
    """``OptionError`` naming the field (a ``ValueError``) if ``value`` is not a whole number in
    ``lo..hi``: a command's fields are its caller's arguments."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise OptionError(name, f"must be an integer in {lo}..{hi}, got {shown(value)}")
    if not lo <= value <= hi:
        raise OptionError(name, f"must be in {lo}..{hi}, got {shown(value)}")  # 10**400: cut


def pack_fields(fields: tuple[Field, ...], values: dict[str, int]) -> bytes:
    """Check every value against its field's range and pack them little-endian."""
    _check_fields(fields, values)
    return _pack(fields, values)


def _pack(fields: tuple[Field, ...], values: dict[str, int]) -> bytes:
    return _layout(fields).pack(*(values[f.name] for f in fields))


@functools.cache
def _layout(fields: tuple[Field, ...]) -> struct.Struct:
    """The fields' little-endian struct, made once per command's fields."""
    return struct.Struct("<" + "".join(f.fmt for f in fields))


def _check_fields(fields: tuple[Field, ...], values: dict[str, int]) -> None:
    expected = [f.name for f in fields]
    if sorted(values) != sorted(expected):
        raise ValueError(f"expected fields {expected}, got {sorted(values)}")
    for f in fields:
        _check_range(f.name, values[f.name], f.lo, f.hi)


def unpack_fields(fields: tuple[Field, ...], params: bytes) -> dict[str, int]:
    values = _layout(fields).unpack(params)
    return dict(zip((f.name for f in fields), values))


def check_request(command: Command, /, **values: int) -> None:
    """``ValueError`` naming the field if ``values`` cannot be sent with ``command`` (a field
    missing or out of its range, or a min not below its max); checks before anything is sent."""
    spec = SPECS[Command(command)]
    _check_fields(spec.request, values)
    if spec.ordered_pair:
        low, high = spec.ordered_pair
        if values[low] >= values[high]:
            raise ValueError(f"{low} must be less than {high}, got {values[low]} >= {values[high]}")


def check_servo_id(servo_id: int) -> None:
    """``OptionError`` (a ``ValueError``) unless ``servo_id`` is a servo's ID or the broadcast
    ID."""
    _check_range("servo_id", servo_id, 0, BROADCAST_ID)


def encode_request(command: Command, servo_id: int, /, **values: int) -> bytes:
    """A request packet; ``ValueError`` naming the field if any argument is out of range."""
    check_request(command, **values)
    return encode_checked(command, servo_id, values)


def encode_checked(command: Command, servo_id: int, values: dict[str, int]) -> bytes:
    """The packet of a request whose ``values`` have passed :func:`check_request` (``ServoBus``
    checks each command once, before anything is sent; its transport then encodes it once)."""
    spec = SPECS[Command(command)]
    return encode_packet(servo_id, spec.command, _pack(spec.request, values))


def field_range(command: Command, name: str) -> tuple[int, int]:
    """The valid range of one of a write command's fields (this table is the one source)."""
    spec = SPECS[Command(command)]
    for f in spec.request:
        if f.name == name:
            return f.lo, f.hi
    names = ", ".join(f.name for f in spec.request) or "none"
    raise ValueError(f"{spec.command.name} has no field {name!r}; its fields: {names}")


def decode_request(packet: Packet) -> dict[str, int]:
    """The field values of a request packet (for the emulator); ``ValueError`` if malformed."""
    spec = SPECS[Command(packet.command)]
    if len(packet.params) + MIN_LEN != spec.request_len:
        raise ValueError(
            f"{spec.command.name} takes LEN {spec.request_len}, got {len(packet.params) + MIN_LEN}"
        )
    return unpack_fields(spec.request, packet.params)


def encode_reply(command: Command, servo_id: int, /, **values: int) -> bytes:
    """A reply packet as a servo sends it (for the emulator and tests)."""
    spec = SPECS[Command(command)]
    if spec.reply is None:
        raise ValueError(f"{spec.command.name} has no reply")
    return encode_packet(servo_id, spec.command, pack_fields(spec.reply, values))


def decode_reply(command: Command, packet: Packet) -> dict[str, int]:
    """The field values of a reply to ``command``; ``ValueError`` if it is not such a reply."""
    spec = SPECS[Command(command)]
    if spec.reply is None:
        raise ValueError(f"{spec.command.name} has no reply")
    if packet.command != spec.command or len(packet.params) + MIN_LEN != spec.reply_len:
        raise ValueError(
            f"not a {spec.command.name} reply: cmd {packet.command}, LEN {len(packet.params) + 3}"
        )
    return unpack_fields(spec.reply, packet.params)


class PacketDecoder(ResyncDecoder[Packet]):
    """Turns a byte stream into packets with valid frames and checksums.

    Resynchronizes on ``55 55`` after garbage, skips frames with a bad checksum or an impossible
    length (without losing a real header inside them), and never raises on any input.
    """

    header = HEADER

    def frame_length(self, buf: bytearray) -> int:
        if len(buf) < 4:
            return MORE
        servo_id, length = buf[2], buf[3]
        if servo_id > BROADCAST_ID or not MIN_LEN <= length <= MAX_LEN:
            return NOT_A_FRAME
        return length + 3

    def intact(self, buf: bytearray, total: int) -> bool:
        return checksum(buf[2 : total - 1]) == buf[total - 1]

    def frame(self, buf: bytearray, total: int) -> Packet:
        return Packet(buf[2], _command_or_int(buf[4]), bytes(buf[5 : total - 1]))


def parse_ids(text: str) -> tuple[int, ...]:
    """Servo IDs from ``"1-6,9,12-14"``, sorted and unique; ``ValueError`` saying what is valid."""
    return tuple(sorted(set(parse_id_sequence(text))))


def parse_id_sequence(text: str) -> tuple[int, ...]:
    """Servo IDs from ``"9-16,1-8"`` in the order written (repeats kept, for the caller to
    judge); ``ValueError`` saying what is valid."""
    ids: list[int] = []
    for part in text.replace(" ", "").split(","):
        low, dash, high = part.partition("-")
        try:
            first, last = int(low), int(high if dash else low)
        except ValueError:
            raise ValueError(f"servo IDs must look like '1-6,9', got {text!r}") from None
        if not 0 <= first <= last <= MAX_SERVO_ID:
            raise ValueError(
                f"servo IDs must be in 0..{MAX_SERVO_ID} with low <= high, got {part!r}"
            )
        ids.extend(range(first, last + 1))
    return tuple(ids)


def _command_or_int(value: int) -> int:
    try:
        return Command(value)
    except ValueError:
        return value
