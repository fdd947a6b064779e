"""A read that got no valid reply, said in one line: silent, garbled (two servos on one ID, a
collision on broadcast), or its echo never seen."""

from __future__ import annotations

import pytest
from servo_bus_helpers import make_bus

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.bus.read_failure import FailedTries, no_reply_error
from choreo.bus.servo_bus import EchoMode, ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ReplyFaults, ServoSpec, connection
from choreo.errors import BusTimeoutError, ProtocolError


def test_exhausted_retries_raise_a_timeout_naming_the_servo():
    bus, emulator = make_bus(retries=1)
    emulator.servo(3).reply_faults = ReplyFaults(drop_next=2)
    with pytest.raises(
        BusTimeoutError,
        match=r"^servo 3 did not answer POS_READ on sim:// "
        r"\(2 tries, 50 ms each\): check power and wiring, or run `choreo scan`$",
    ) as caught:
        bus.read_position(3)
    assert (caught.value.servo_id, caught.value.command) == (3, Command.POS_READ)
    assert isinstance(BusTimeoutError("x"), TimeoutError)
    assert bus.read_position(3) == 500  # the bus is usable again


def test_persistent_corruption_is_a_protocol_error():
    bus, emulator = make_bus(retries=1)
    emulator.servo(2).reply_faults = ReplyFaults(corrupt_probability=1.0)
    with pytest.raises(
        ProtocolError,
        match=r"servo 2: 2 replies to VIN_READ failed the checksum \(2 tries, 50 ms each\)",
    ) as caught:
        bus.read_vin(2)
    assert (caught.value.servo_id, caught.value.command) == (2, Command.VIN_READ)


def test_duplicate_ids_garble_replies_and_say_so():
    emulator = BusEmulator([ServoSpec(1), ServoSpec(1)], clock=VirtualClock())
    bus = ServoBus(connection(emulator), retries=0)
    with pytest.raises(ProtocolError, match="two servos may share ID 1"):
        bus.read_position(1)


def test_discard_mode_without_echo_says_what_to_try():
    bus, _ = make_bus(echo=False, mode=EchoMode.DISCARD, retries=0)
    with pytest.raises(ProtocolError, match="expected the echo of the request.*echo mode"):
        bus.read_position(1)


def test_silent_broadcast_says_no_servo_answered():
    bus, _ = make_bus(ids=(), retries=0)
    with pytest.raises(
        BusTimeoutError,
        match=r"^no servo answered ID_READ on sim:// \(1 try of 50 ms\): check power",
    ):
        bus.read_id()


def test_colliding_broadcast_replies_say_several_servos_answered():
    bus, _ = make_bus(ids=(1, 2), retries=0)
    with pytest.raises(
        ProtocolError,
        match=r"^1 reply to a broadcast ID_READ failed the checksum "
        r"\(1 try of 50 ms\): several servos answered at once",
    ):
        bus.read_id()


@pytest.mark.parametrize(
    "servo_id, tries, kind, words",
    [
        (3, FailedTries(1, 0.02, 0, True, b""), BusTimeoutError, "servo 3 did not answer POS_READ"),
        (BROADCAST_ID, FailedTries(3, 0.05, 0, True, b""), BusTimeoutError, "no servo answered"),
        (3, FailedTries(2, 0.05, 1, True, b""), ProtocolError, "1 reply to POS_READ failed"),
        (3, FailedTries(1, 0.05, 0, False, b"\x55\x55"), ProtocolError, "got 55 55: is the bus"),
    ],
)
def test_the_error_says_what_the_tries_saw(servo_id, tries, kind, words):
    error = no_reply_error("/dev/ttyUSB0", servo_id, Command.POS_READ, tries)
    assert type(error) is kind and words in str(error)
    assert (error.servo_id, error.command) == (
        None if servo_id == BROADCAST_ID else servo_id,
        Command.POS_READ,
    )


def test_the_tries_are_counted_with_each_ones_timeout():
    assert FailedTries(1, 0.02, 0, True, b"").text == "1 try of 20 ms"
    assert FailedTries(3, 0.05, 0, True, b"").text == "3 tries, 50 ms each"
