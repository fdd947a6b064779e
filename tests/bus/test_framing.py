"""choreo.bus.framing: the one resync core behind the LX, RRC and LOBOT decoders. Each property
is checked on all three framings, with frames of each."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from choreo.bus.framing import MORE, NOT_A_FRAME, ResyncDecoder
from choreo.bus.protocol import Command, PacketDecoder, encode_reply, encode_request
from choreo.bus.transports import lobot, rrc

# decoder, three frames, a header followed by what cannot start a frame
FRAMINGS = {
    "LX": (
        PacketDecoder,
        [
            encode_reply(Command.POS_READ, 1, pos_units=500),
            encode_request(Command.MOVE_TIME_WRITE, 2, pos_units=300, time_ms=1000),
            encode_request(Command.MOVE_START, 0xFE),
        ],
        b"\x55\x55\xff",  # ID 255
    ),
    "RRC": (
        rrc.FrameDecoder,
        [
            rrc.encode_frame(rrc.FUNC_BUS_SERVO, bytes((1, 5, 0, 0xF4, 1))),
            rrc.encode_frame(rrc.FUNC_SYS, bytes((rrc.SYS_BATTERY, 0xE8, 0x1C))),
            rrc.move_frame([(1, 500), (2, 300)], 1000),
        ],
        b"\xaa\x55\x0c",  # FUNC 12
    ),
    "LOBOT": (
        lobot.FrameDecoder,
        [
            lobot.encode_frame(lobot.READ_POSITIONS, bytes((1, 1, 0xF4, 1))),
            lobot.battery_frame(),
            lobot.move_frame([(1, 500), (2, 300)], 1000),
        ],
        b"\x55\x55\x01",  # LEN 1
    ),
}
NAMES = list(FRAMINGS)


@pytest.mark.parametrize("name", NAMES)
def test_every_decoder_is_the_shared_core(name):
    make, _, _ = FRAMINGS[name]
    assert isinstance(make(), ResyncDecoder)


@pytest.mark.parametrize("name", NAMES)
def test_frames_fed_a_byte_at_a_time_come_out_as_fed_whole(name):
    make, frames, _ = FRAMINGS[name]
    stream = b"".join(frames)
    whole = make().feed(stream)
    decoder = make()
    assert [f for b in stream for f in decoder.feed(bytes((b,)))] == whole
    assert len(whole) == len(frames)


@pytest.mark.parametrize("name", NAMES)
def test_garbage_and_false_headers_between_frames_are_skipped(name):
    make, frames, false_start = FRAMINGS[name]
    # a lone header byte, a header followed by what cannot start a frame, plain garbage
    stream = make.header[:1] + b"\x13" + frames[0] + false_start + frames[1] + b"\x00" + frames[2]
    decoder = make()
    assert decoder.feed(stream) == make().feed(b"".join(frames))
    assert decoder.discarded_bytes == 2 + len(false_start) + 1


@pytest.mark.parametrize("name", ["LX", "RRC"])
def test_a_frame_failing_its_checksum_is_counted_and_a_header_inside_it_is_found(name):
    make, frames, _ = FRAMINGS[name]
    damaged = bytearray(frames[0])
    damaged[-1] ^= 0x5A
    decoder = make()
    got = decoder.feed(bytes(damaged[:-1]) + frames[1] + bytes(damaged[-1:]) + frames[2])
    assert got == make().feed(frames[1] + frames[2])
    assert decoder.bad_checksums == 1


@pytest.mark.parametrize("name", NAMES)
def test_bytes_to_complete_asks_for_what_the_begun_frame_lacks(name):
    make, frames, _ = FRAMINGS[name]
    frame = frames[2]
    decoder = make()
    assert decoder.bytes_to_complete(30) == 30  # nothing begun: the caller's expectation
    decoder.feed(frame[:1])
    assert decoder.bytes_to_complete(30) == 29  # a lone header byte
    decoder.feed(frame[1:5])
    assert decoder.bytes_to_complete(30) == len(frame) - 5  # the length byte has come
    assert decoder.feed(frame[5:]) == make().feed(frame)
    assert decoder.bytes_to_complete(30) == 30


@pytest.mark.parametrize("name", NAMES)
def test_reset_drops_a_frame_begun(name):
    make, frames, _ = FRAMINGS[name]
    decoder = make()
    decoder.feed(frames[0][:-1])
    decoder.reset()
    assert decoder.feed(frames[0][-1:] + frames[1]) == make().feed(frames[1])


def test_a_framing_says_only_its_length_checksum_and_value():
    """A new framing is three short methods: here frames ``7E 7E LEN DATA``."""

    class Tiny(ResyncDecoder[bytes]):
        header = b"\x7e\x7e"

        def frame_length(self, buf: bytearray) -> int:
            if len(buf) < 3:
                return MORE
            return 3 + buf[2] if buf[2] < 8 else NOT_A_FRAME

        def frame(self, buf: bytearray, total: int) -> bytes:
            return bytes(buf[3:total])

    decoder = Tiny()
    assert decoder.feed(b"\x01\x7e\x7e\x09\x7e\x7e\x02ab\x7e") == [b"ab"]
    assert decoder.feed(b"\x7e\x00") == [b""]
    assert decoder.bad_checksums == 0 and decoder.discarded_bytes == 4


@settings(max_examples=200)
@given(st.sampled_from(NAMES), st.binary(max_size=200))
def test_no_input_makes_a_decoder_raise(name, data):
    make, _, _ = FRAMINGS[name]
    decoder = make()
    decoder.feed(data)
    assert decoder.bytes_to_complete(8) > 0  # a reader never asks for nothing
