"""Faults injected into an emulated servo's replies: dropped, corrupted, reproducible from the
seed."""

from __future__ import annotations

import re

import pytest
from emulator_helpers import Bus

from choreo.bus.protocol import (
    Command as C,
)
from choreo.bus.protocol import (
    PacketDecoder,
)
from choreo.emulator import ReplyFate, ReplyFaults


def test_dropped_replies_time_out_then_the_servo_answers_again(bus):
    servo = bus.emulator.servo(1)
    servo.reply_faults = ReplyFaults(drop_next=2)
    assert bus.raw_reply(C.POS_READ, 1) == b""
    assert bus.raw_reply(C.POS_READ, 1) == b""
    assert bus.position() == 500
    assert [r.fate for r in bus.emulator.log.replies] == [
        ReplyFate.DROPPED,
        ReplyFate.DROPPED,
        ReplyFate.SENT,
    ]


def test_corrupted_replies_fail_the_checksum(bus):
    bus.emulator.servo(1).reply_faults = ReplyFaults(corrupt_next=1)
    data = bus.raw_reply(C.POS_READ, 1)
    decoder = PacketDecoder()
    assert len(data) == 8 and decoder.feed(data) == [] and decoder.bad_checksums == 1
    assert bus.position() == 500


def test_random_reply_faults_are_reproducible_from_the_seed():
    def fates(seed):
        bus = Bus(seed=seed)
        bus.emulator.servo(1).reply_faults = ReplyFaults(
            drop_probability=0.3, corrupt_probability=0.3
        )
        for _ in range(60):
            bus.raw_reply(C.POS_READ, 1)
        return [r.fate for r in bus.emulator.log.replies]

    first = fates(seed=4)
    assert first == fates(seed=4)
    assert first != fates(seed=5)
    assert {ReplyFate.SENT, ReplyFate.DROPPED, ReplyFate.CORRUPTED} == set(first)


def test_counted_faults_come_first_and_are_used_up_one_reply_each():
    faults = ReplyFaults(drop_next=1, corrupt_next=1)
    fates = []
    for _ in range(3):
        fate, faults = faults.take(lambda: 0.0)
        fates.append(fate)
    assert fates == [ReplyFate.DROPPED, ReplyFate.CORRUPTED, ReplyFate.SENT]
    assert faults == ReplyFaults()


def test_a_fault_probability_is_drawn_against_and_not_used_up():
    faults = ReplyFaults(drop_probability=0.5)
    assert faults.take(lambda: 0.4) == (ReplyFate.DROPPED, faults)
    assert faults.take(lambda: 0.6) == (ReplyFate.SENT, faults)


@pytest.mark.parametrize(
    "fields, words",
    [
        (dict(drop_next=-1), "drop_next must be >= 0, got -1"),
        (dict(corrupt_probability=1.5), "corrupt_probability must be in 0..1, got 1.5"),
    ],
)
def test_impossible_faults_are_refused_by_name(fields, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        ReplyFaults(**fields)
