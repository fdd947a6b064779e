"""The codec against the 58 verified packets of docs/protocol.md (from the vendor manual
and two independent drivers), plus property tests of the stream decoder."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from choreo.bus.protocol import (
    BROADCAST_ID,
    SPECS,
    Command,
    Packet,
    PacketDecoder,
    check_request,
    checksum,
    decode_reply,
    decode_request,
    encode_packet,
    encode_reply,
    encode_request,
    field_range,
    parse_ids,
)

C = Command
B = BROADCAST_ID

# (command, servo id, request fields, request bytes, reply fields or None, reply bytes or None)
GOLDEN = [
    (
        C.MOVE_TIME_WRITE,
        1,
        dict(pos_units=500, time_ms=1000),
        "55 55 01 07 01 F4 01 E8 03 16",
        None,
        None,
    ),
    (
        C.MOVE_TIME_WRITE,
        1,
        dict(pos_units=1000, time_ms=2000),
        "55 55 01 07 01 E8 03 D0 07 34",
        None,
        None,
    ),
    (
        C.MOVE_TIME_WRITE,
        1,
        dict(pos_units=500, time_ms=2000),
        "55 55 01 07 01 F4 01 D0 07 2A",
        None,
        None,
    ),
    (
        C.OR_MOTOR_MODE_WRITE,
        1,
        dict(mode=1, reserved=0, speed=-500),
        "55 55 01 07 1D 01 00 0C FE CF",
        None,
        None,
    ),
    (C.ANGLE_OFFSET_ADJUST, 1, dict(offset_units=-10), "55 55 01 04 11 F6 F3", None, None),
    (C.MOVE_START, B, {}, "55 55 FE 03 0B F3", None, None),
    (
        C.MOVE_TIME_WRITE,
        B,
        dict(pos_units=0, time_ms=0),
        "55 55 FE 07 01 00 00 00 00 F9",
        None,
        None,
    ),
    (
        C.MOVE_TIME_READ,
        1,
        {},
        "55 55 01 03 02 F9",
        dict(pos_units=500, time_ms=1000),
        "55 55 01 07 02 F4 01 E8 03 15",
    ),
    (
        C.MOVE_TIME_WAIT_WRITE,
        2,
        dict(pos_units=300, time_ms=500),
        "55 55 02 07 07 2C 01 F4 01 CD",
        None,
        None,
    ),
    (
        C.MOVE_TIME_WAIT_READ,
        2,
        {},
        "55 55 02 03 08 F2",
        dict(pos_units=300, time_ms=500),
        "55 55 02 07 08 2C 01 F4 01 CC",
    ),
    (C.MOVE_START, 2, {}, "55 55 02 03 0B EF", None, None),
    (C.MOVE_STOP, 1, {}, "55 55 01 03 0C EF", None, None),
    (C.ID_WRITE, 1, dict(new_id=5), "55 55 01 04 0D 05 E8", None, None),
    (C.ID_READ, B, {}, "55 55 FE 03 0E F0", dict(servo_id=1), "55 55 01 04 0E 01 EB"),
    (C.ID_READ, 5, {}, "55 55 05 03 0E E9", dict(servo_id=5), "55 55 05 04 0E 05 E3"),
    (C.ANGLE_OFFSET_ADJUST, 1, dict(offset_units=125), "55 55 01 04 11 7D 6C", None, None),
    (C.ANGLE_OFFSET_WRITE, 1, {}, "55 55 01 03 12 E9", None, None),
    (
        C.ANGLE_OFFSET_READ,
        1,
        {},
        "55 55 01 03 13 E8",
        dict(offset_units=-10),
        "55 55 01 04 13 F6 F1",
    ),
    (
        C.ANGLE_LIMIT_WRITE,
        1,
        dict(min_units=100, max_units=900),
        "55 55 01 07 14 64 00 84 03 F8",
        None,
        None,
    ),
    (
        C.ANGLE_LIMIT_READ,
        1,
        {},
        "55 55 01 03 15 E6",
        dict(min_units=0, max_units=1000),
        "55 55 01 07 15 00 00 E8 03 F7",
    ),
    (
        C.VIN_LIMIT_WRITE,
        1,
        dict(min_mv=4500, max_mv=12000),
        "55 55 01 07 16 94 11 E0 2E 2E",
        None,
        None,
    ),
    (
        C.VIN_LIMIT_READ,
        1,
        {},
        "55 55 01 03 17 E4",
        dict(min_mv=4500, max_mv=14000),
        "55 55 01 07 17 94 11 B0 36 55",
    ),
    (C.TEMP_MAX_LIMIT_WRITE, 1, dict(temp_c=85), "55 55 01 04 18 55 8D", None, None),
    (C.TEMP_MAX_LIMIT_READ, 1, {}, "55 55 01 03 19 E2", dict(temp_c=85), "55 55 01 04 19 55 8C"),
    (C.TEMP_READ, 1, {}, "55 55 01 03 1A E1", dict(temp_c=31), "55 55 01 04 1A 1F C1"),
    (C.VIN_READ, 1, {}, "55 55 01 03 1B E0", dict(vin_mv=7400), "55 55 01 05 1B E8 1C DA"),
    (C.POS_READ, 1, {}, "55 55 01 03 1C DF", dict(pos_units=500), "55 55 01 05 1C F4 01 E8"),
    (C.POS_READ, 1, {}, "55 55 01 03 1C DF", dict(pos_units=-12), "55 55 01 05 1C F4 FF EA"),
    (C.POS_READ, 1, {}, "55 55 01 03 1C DF", dict(pos_units=1130), "55 55 01 05 1C 6A 04 6F"),
    (
        C.OR_MOTOR_MODE_WRITE,
        1,
        dict(mode=1, reserved=0, speed=1000),
        "55 55 01 07 1D 01 00 E8 03 EE",
        None,
        None,
    ),
    (
        C.OR_MOTOR_MODE_WRITE,
        1,
        dict(mode=0, reserved=0, speed=0),
        "55 55 01 07 1D 00 00 00 00 DA",
        None,
        None,
    ),
    (
        C.OR_MOTOR_MODE_READ,
        1,
        {},
        "55 55 01 03 1E DD",
        dict(mode=1, reserved=0, speed=-500),
        "55 55 01 07 1E 01 00 0C FE CE",
    ),
    (C.LOAD_OR_UNLOAD_WRITE, 1, dict(loaded=1), "55 55 01 04 1F 01 DA", None, None),
    (C.LOAD_OR_UNLOAD_WRITE, B, dict(loaded=0), "55 55 FE 04 1F 00 DE", None, None),
    (C.LOAD_OR_UNLOAD_READ, 1, {}, "55 55 01 03 20 DB", dict(loaded=1), "55 55 01 04 20 01 D9"),
    (C.LED_CTRL_WRITE, 1, dict(led_off=1), "55 55 01 04 21 01 D8", None, None),
    (C.LED_CTRL_READ, 1, {}, "55 55 01 03 22 D9", dict(led_off=0), "55 55 01 04 22 00 D8"),
    (C.LED_ERROR_WRITE, 1, dict(mask=7), "55 55 01 04 23 07 D0", None, None),
    (C.LED_ERROR_READ, 1, {}, "55 55 01 03 24 D7", dict(mask=7), "55 55 01 04 24 07 CF"),
    (C.DIS_READ, 1, {}, "55 55 01 03 30 CB", dict(distance=74801), "55 55 01 07 30 31 24 01 00 71"),
]


def test_golden_table_holds_all_58_packets():
    assert len(GOLDEN) + sum(1 for row in GOLDEN if row[5]) == 58


@pytest.mark.parametrize("command, servo_id, fields, request_hex, reply_fields, reply_hex", GOLDEN)
def test_golden_request_bytes(command, servo_id, fields, request_hex, reply_fields, reply_hex):
    assert encode_request(command, servo_id, **fields) == bytes.fromhex(request_hex)


@pytest.mark.parametrize("command, servo_id, fields, request_hex, reply_fields, reply_hex", GOLDEN)
def test_golden_request_decodes(command, servo_id, fields, request_hex, reply_fields, reply_hex):
    [packet] = PacketDecoder().feed(bytes.fromhex(request_hex))
    assert (packet.servo_id, packet.command) == (servo_id, command)
    assert decode_request(packet) == fields


@pytest.mark.parametrize(
    "command, servo_id, fields, request_hex, reply_fields, reply_hex", [g for g in GOLDEN if g[5]]
)
def test_golden_reply(command, servo_id, fields, request_hex, reply_fields, reply_hex):
    [packet] = PacketDecoder().feed(bytes.fromhex(reply_hex))
    assert decode_reply(command, packet) == reply_fields
    replying_id = packet.servo_id
    assert encode_reply(command, replying_id, **reply_fields) == bytes.fromhex(reply_hex)


def test_every_command_of_the_document_is_in_the_table():
    assert sorted(SPECS) == [
        1,
        2,
        7,
        8,
        11,
        12,
        13,
        14,
        17,
        18,
        19,
        20,
        21,
        22,
        23,
        24,
        25,
        26,
        27,
        28,
        29,
        30,
        31,
        32,
        33,
        34,
        35,
        36,
        48,
    ]
    assert SPECS[C.DIS_READ].reply_len == 7
    assert (
        SPECS[C.ANGLE_OFFSET_READ].reply_len == 4
    )  # not "9 / length 7" as the English edition says


@pytest.mark.parametrize(
    "command, fields, message",
    [
        (
            C.MOVE_TIME_WRITE,
            dict(pos_units=1001, time_ms=0),
            "pos_units must be in 0..1000, got 1001",
        ),
        (C.MOVE_TIME_WRITE, dict(pos_units=-1, time_ms=0), "pos_units must be in 0..1000, got -1"),
        (C.MOVE_TIME_WAIT_WRITE, dict(pos_units=0, time_ms=30001), "time_ms must be in 0..30000"),
        (C.ANGLE_OFFSET_ADJUST, dict(offset_units=126), "offset_units must be in -125..125"),
        (
            C.ANGLE_LIMIT_WRITE,
            dict(min_units=900, max_units=100),
            "min_units must be less than max_units",
        ),
        (C.VIN_LIMIT_WRITE, dict(min_mv=4000, max_mv=12000), "min_mv must be in 4500..14000"),
        (C.TEMP_MAX_LIMIT_WRITE, dict(temp_c=101), "temp_c must be in 50..100"),
        (
            C.OR_MOTOR_MODE_WRITE,
            dict(mode=1, reserved=0, speed=1001),
            "speed must be in -1000..1000",
        ),
        (C.OR_MOTOR_MODE_WRITE, dict(mode=2, reserved=0, speed=0), "mode must be in 0..1"),
        (C.LED_ERROR_WRITE, dict(mask=8), "mask must be in 0..7"),
        (C.ID_WRITE, dict(new_id=254), "new_id must be in 0..253"),
        (C.MOVE_TIME_WRITE, dict(pos_units=2.5, time_ms=0), "pos_units must be an integer"),
        (C.MOVE_TIME_WRITE, dict(pos_units=1), "expected fields"),
    ],
)
def test_out_of_range_arguments_name_the_field(command, fields, message):
    with pytest.raises(ValueError, match=message):
        encode_request(command, 1, **fields)
    with pytest.raises(ValueError, match=message):  # the same check, before anything is sent
        check_request(command, **fields)


def test_check_request_accepts_what_encode_request_encodes():
    assert check_request(C.ANGLE_LIMIT_WRITE, min_units=100, max_units=900) is None
    assert encode_request(C.ANGLE_LIMIT_WRITE, 1, min_units=100, max_units=900) == bytes.fromhex(
        "55 55 01 07 14 64 00 84 03 F8"
    )


def test_field_range_from_the_table_of_protocol_md():
    assert field_range(C.ANGLE_OFFSET_ADJUST, "offset_units") == (-125, 125)
    assert field_range(C.MOVE_TIME_WRITE, "time_ms") == (0, 30000)
    assert field_range(C.ID_WRITE, "new_id") == (0, 253)
    with pytest.raises(
        ValueError,
        match=r"ANGLE_LIMIT_WRITE has no field 'min'; its fields: "
        "min_units, max_units",
    ):
        field_range(C.ANGLE_LIMIT_WRITE, "min")


def test_servo_id_range():
    with pytest.raises(ValueError, match="servo_id must be in 0..254, got 255"):
        encode_request(C.MOVE_STOP, 255)


# --- the stream decoder ------------------------------------------------------------------------
GOOD = [bytes.fromhex(row[3]) for row in GOLDEN] + [
    bytes.fromhex(row[5]) for row in GOLDEN if row[5]
]


def test_resynchronizes_after_garbage_and_bad_checksum():
    good = bytes.fromhex("55 55 01 05 1C F4 01 E8")
    bad = bytes.fromhex("55 55 01 05 1C F4 01 E9")
    decoder = PacketDecoder()
    packets = decoder.feed(b"\x00\x55\x13" + bad + b"\x55" + good + b"\x55\x55\x55" + good)
    assert [p.encode() for p in packets] == [good, good]
    assert decoder.bad_checksums == 1


def test_impossible_length_is_skipped_without_losing_a_following_packet():
    good = bytes.fromhex("55 55 01 04 0E 01 EB")
    packets = PacketDecoder().feed(bytes.fromhex("55 55 01 09") + good)
    assert [p.encode() for p in packets] == [good]


def test_packet_split_across_feeds():
    good = bytes.fromhex("55 55 01 07 30 31 24 01 00 71")
    decoder = PacketDecoder()
    assert [p for b in good[:-1] for p in decoder.feed(bytes([b]))] == []
    assert decoder.feed(good[-1:]) == [Packet(1, C.DIS_READ, bytes.fromhex("31 24 01 00"))]


def test_bytes_to_complete_counts_from_the_length_byte_once_it_has_arrived():
    reply = bytes.fromhex("55 55 01 07 30 31 24 01 00 71")  # 10 bytes, LEN 7
    decoder = PacketDecoder()
    assert decoder.bytes_to_complete(8) == 8  # nothing begun: the caller's expected length
    decoder.feed(reply[:1])
    assert decoder.bytes_to_complete(8) == 7  # a lone 0x55 may start a header
    decoder.feed(reply[1:3])
    assert decoder.bytes_to_complete(8) == 5  # header and ID, no LEN yet: still the expected length
    decoder.feed(reply[3:6])
    assert decoder.bytes_to_complete(8) == 4  # LEN 7 says the frame is 10 bytes long
    assert decoder.feed(reply[6:]) == [Packet(1, C.DIS_READ, bytes.fromhex("31 24 01 00"))]
    assert decoder.feed(b"\x13\x37") == [] and decoder.bytes_to_complete(8) == 8  # garbage dropped


@settings(max_examples=300)
@given(st.binary(max_size=300))
def test_never_raises_and_never_yields_a_bad_checksum(data):
    decoder = PacketDecoder()
    for packet in decoder.feed(data):
        raw = packet.encode()
        assert checksum(raw[2:-1]) == raw[-1]
        assert 3 <= raw[3] <= 7


@settings(max_examples=200)
@given(
    st.lists(st.tuples(st.binary(max_size=12), st.sampled_from(GOOD)), min_size=1, max_size=8),
)
def test_finds_every_good_packet_among_garbage_without_headers(chunks):
    """Garbage that holds no 0x55 can never hide a packet: every good one comes out, in order."""
    stream = b"".join(g.replace(b"\x55", b"\x00") + p for g, p in chunks)
    decoder = PacketDecoder()
    assert [p.encode() for p in decoder.feed(stream)] == [p for _, p in chunks]


@settings(max_examples=200)
@given(st.sampled_from(GOOD), st.integers(0, 9), st.integers(1, 255))
def test_a_corrupted_byte_never_passes(packet, index, flip):
    index %= len(packet)
    corrupted = bytearray(packet)
    corrupted[index] ^= flip
    decoded = PacketDecoder().feed(bytes(corrupted))
    # With the frame length unchanged, any single changed byte after the header fails the
    # checksum. (A changed LEN byte moves the frame: a coincidental match there is legitimate.)
    if index != 3:
        assert all(p.encode() != packet for p in decoded)
    if index >= 4:
        assert decoded == []


def test_encode_packet_frames_raw_params():
    assert encode_packet(1, 28) == bytes.fromhex("55 55 01 03 1C DF")


def test_parse_ids():
    assert parse_ids("1-3, 9,2") == (1, 2, 3, 9)
    assert parse_ids("253") == (253,)
    for bad, message in [("0-254", "0..253"), ("5-2", "low <= high"), ("a", "look like")]:
        with pytest.raises(ValueError, match=message):
            parse_ids(bad)
