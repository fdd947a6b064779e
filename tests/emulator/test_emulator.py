"""The servo emulator driven by raw packets on a virtual clock.

Golden reply bytes come from the verified packets of docs/protocol.md; speeds and times
from docs/servo-models.md (LX-16A: 0.16 s/60°, so 240° = 1000 units take 0.64 s).
"""

from __future__ import annotations

import pytest
from emulator_helpers import BYTE_S, TIMEOUT_S, TURNAROUND_S, Bus, hexbytes
from fifo_helpers import fifo_that_never_blocks

from choreo.bus.protocol import (
    BROADCAST_ID,
    PacketDecoder,
    encode_packet,
    encode_request,
)
from choreo.bus.protocol import (
    Command as C,
)
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ReplyFate
from choreo.errors import ChoreoError, OptionError


# --- wire timing --------------------------------------------------------------------------------
def test_read_reply_completes_after_request_turnaround_and_reply_bytes(bus):
    bus.port.write(encode_request(C.POS_READ, 1))
    assert bus.clock.now() == 0.0  # writing is buffered: no time passes
    assert bus.port.read(8) == hexbytes("55 55 01 05 1C F4 01 E8")
    assert bus.clock.now() == pytest.approx(6 * BYTE_S + TURNAROUND_S + 8 * BYTE_S, abs=1e-12)


def test_reply_bytes_arrive_one_byte_time_apart(bus):
    bus.port.write(encode_request(C.POS_READ, 1))
    assert bus.port.read(1) == b"\x55"
    assert bus.clock.now() == pytest.approx(6 * BYTE_S + TURNAROUND_S + BYTE_S, abs=1e-12)
    assert bus.port.in_waiting == 0
    bus.wait(3 * BYTE_S)
    assert bus.port.in_waiting == 3


def test_turnaround_is_configurable():
    bus = Bus(turnaround_s=0.005)
    bus.port.write(encode_request(C.POS_READ, 1))
    bus.port.read(8)
    assert bus.clock.now() == pytest.approx(14 * BYTE_S + 0.005, abs=1e-12)


def test_timeout_advances_the_virtual_clock_by_exactly_the_timeout(bus):
    bus.port.write(encode_request(C.POS_READ, 7))  # nobody has ID 7
    assert bus.port.read(8) == b""
    assert bus.clock.now() == TIMEOUT_S


def test_flush_advances_to_when_the_wire_is_free_and_writes_queue(bus):
    bus.port.write(encode_request(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=1000))
    bus.port.write(encode_request(C.MOVE_STOP, 1))
    assert bus.port.out_waiting == 16
    bus.port.flush()
    assert bus.clock.now() == pytest.approx(16 * BYTE_S, abs=1e-12)
    assert bus.port.out_waiting == 0
    arrivals = [entry.time_s for entry in bus.emulator.log.packets]
    assert arrivals == pytest.approx([10 * BYTE_S, 16 * BYTE_S], abs=1e-12)


def test_a_servo_acts_only_when_the_last_byte_has_arrived(bus):
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    packet = encode_request(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=0)
    start = bus.clock.now()
    bus.port.write(packet)
    bus.clock.sleep_until(start + 9.5 * BYTE_S)
    assert bus.emulator.servo(1).position_units == 500
    bus.clock.sleep_until(start + 10 * BYTE_S)
    (move,) = bus.emulator.log.moves
    assert move.time_s == pytest.approx(start + 10 * BYTE_S, abs=1e-12)


def test_reset_output_buffer_drops_bytes_not_yet_on_the_wire(bus):
    bus.port.write(encode_request(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=0))
    bus.wait(3.5 * BYTE_S)  # the 4th byte is on the wire
    bus.port.reset_output_buffer()
    assert bus.port.out_waiting == 1
    bus.port.write(encode_request(C.POS_READ, 1))
    assert bus.port.read(8) == hexbytes("55 55 01 05 1C F4 01 E8")  # the torn packet was ignored
    assert [p.packet.command for p in bus.emulator.log.packets] == [C.POS_READ]


def test_reset_input_buffer_drops_arrived_bytes_but_a_late_reply_still_arrives(bus):
    bus.port.write(encode_request(C.POS_READ, 1))
    bus.port.read(3)
    bus.port.reset_input_buffer()
    assert bus.port.read(8) == hexbytes("05 1C F4 01 E8")  # the tail was still on its way


# --- echo ---------------------------------------------------------------------------------------
def test_echo_returns_the_request_bytes_before_the_reply():
    bus = Bus(echo=True)
    request = encode_request(C.POS_READ, 1)
    bus.port.write(request)
    assert bus.port.read(6) == request
    assert bus.clock.now() == pytest.approx(6 * BYTE_S, abs=1e-12)
    assert bus.port.read(8) == hexbytes("55 55 01 05 1C F4 01 E8")


def test_no_echo_by_default_and_echo_can_be_switched(bus):
    bus.send(C.MOVE_STOP, 1)
    assert bus.port.in_waiting == 0
    bus.emulator.echo = True
    bus.send(C.MOVE_STOP, 1)
    assert bus.port.read(6) == encode_request(C.MOVE_STOP, 1)


# --- broadcast ----------------------------------------------------------------------------------
def test_broadcast_writes_reach_every_servo_without_reply():
    bus = Bus([1, 2, 3])
    bus.send(C.MOVE_TIME_WRITE, BROADCAST_ID, pos_units=0, time_ms=0)
    bus.wait(TIMEOUT_S)
    assert bus.port.in_waiting == 0
    bus.wait(1.0)
    assert [bus.position(i) for i in (1, 2, 3)] == [0, 0, 0]


def test_broadcast_reads_get_no_reply_except_id_read():
    bus = Bus([5])
    assert bus.raw_reply(C.POS_READ, BROADCAST_ID) == b""
    assert bus.raw_reply(C.TEMP_READ, BROADCAST_ID) == b""
    assert bus.raw_reply(C.ID_READ, BROADCAST_ID) == hexbytes("55 55 05 04 0E 05 E3")


def test_broadcast_id_write_renumbers_every_servo():
    bus = Bus([1, 2])
    bus.send(C.ID_WRITE, BROADCAST_ID, new_id=9)
    assert [s.servo_id for s in bus.emulator.servos] == [9, 9]


# --- collisions ---------------------------------------------------------------------------------
def test_duplicate_ids_garble_each_others_replies_into_checksum_errors():
    bus = Bus([1, 1])  # same ID, same state: identical replies still collide
    data = bus.raw_reply(C.POS_READ, 1)
    assert len(data) == 8
    decoder = PacketDecoder()
    assert decoder.feed(data) == []
    assert decoder.bad_checksums == 1
    (reply,) = bus.emulator.log.replies
    assert reply.fate is ReplyFate.COLLIDED and reply.servo_ids == (1, 1)


def test_broadcast_id_read_with_several_servos_is_garbage():
    bus = Bus([1, 2, 3])
    data = bus.raw_reply(C.ID_READ, BROADCAST_ID)
    assert data and PacketDecoder().feed(data) == []


def test_targets_are_clamped_to_the_angle_limits(bus):
    bus.send(C.ANGLE_LIMIT_WRITE, 1, min_units=100, max_units=900)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=0)
    bus.wait(1.0)
    assert bus.position() == 900
    assert bus.read(C.MOVE_TIME_READ) == {"pos_units": 900, "time_ms": 0}
    bus.port.write(encode_packet(1, C.MOVE_TIME_WRITE, bytes.fromhex("0000 0000")))
    bus.wait(1.0)
    assert bus.position() == 100


def test_positions_beyond_1000_on_the_wire_are_clamped(bus):
    bus.port.write(encode_packet(1, C.MOVE_TIME_WRITE, (1200).to_bytes(2, "little") + b"\0\0"))
    bus.wait(1.0)
    assert bus.position() == 1000


def test_broadcast_start_starts_every_staged_servo_at_the_same_instant():
    bus = Bus([1, 2, 3])
    for servo_id, pos_units in ((1, 100), (2, 200), (3, 300)):
        bus.port.write(
            encode_request(C.MOVE_TIME_WAIT_WRITE, servo_id, pos_units=pos_units, time_ms=200)
        )
    bus.port.flush()
    bus.wait(0.001)  # protocol.md: leave >= 1 ms before START
    bus.send(C.MOVE_START, BROADCAST_ID)
    moves = list(bus.emulator.log.moves)
    assert [m.servo_id for m in moves] == [1, 2, 3]
    assert len({m.time_s for m in moves}) == 1
    bus.wait(1.0)
    assert [bus.position(i) for i in (1, 2, 3)] == [100, 200, 300]


def test_servo_powers_up_unloaded_and_load_unload_work(bus):
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}
    bus.send(C.LOAD_OR_UNLOAD_WRITE, BROADCAST_ID, loaded=0)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}


def test_unload_mid_move_stops_and_a_move_reloads(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=1000)
    bus.wait(0.5)
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=0)
    bus.wait(0.5)
    assert bus.position() == 750
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=700, time_ms=0)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}
    bus.wait(0.5)
    assert bus.position() == 700


def test_move_by_hand_only_when_unloaded(bus):
    servo = bus.emulator.servo(1)
    servo.move_by_hand(-12)
    assert bus.raw_reply(C.POS_READ, 1) == hexbytes("55 55 01 05 1C F4 FF EA")
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    with pytest.raises(ValueError, match="unload it"):
        servo.move_by_hand(300)
    with pytest.raises(ValueError, match="pos_units"):
        bus.emulator.servo(1).move_by_hand(2000)


def test_move_stop_does_not_stop_motor_mode_but_speed_zero_does(bus):
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=-200)
    bus.send(C.MOVE_STOP, 1)
    before = bus.emulator.servo(1).output_units
    bus.wait(0.1)
    assert bus.emulator.servo(1).output_units < before
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=0)
    stopped = bus.emulator.servo(1).output_units
    bus.wait(0.1)
    assert bus.emulator.servo(1).output_units == stopped


# --- EEPROM persistence -------------------------------------------------------------------------
def test_eeprom_values_persist_across_a_restart_and_unsaved_ones_do_not(tmp_path):
    state = tmp_path / "bus.json"
    bus = Bus([1, 2], state_path=state)
    bus.send(C.ID_WRITE, 2, new_id=7)
    bus.send(C.ANGLE_OFFSET_ADJUST, 1, offset_units=12)
    bus.send(C.ANGLE_OFFSET_WRITE, 1)
    bus.send(C.ANGLE_OFFSET_ADJUST, 1, offset_units=-30)  # not saved
    bus.send(C.ANGLE_LIMIT_WRITE, 1, min_units=100, max_units=900)
    bus.send(C.VIN_LIMIT_WRITE, 1, min_mv=5000, max_mv=9000)
    bus.send(C.TEMP_MAX_LIMIT_WRITE, 1, temp_c=70)
    bus.send(C.LED_CTRL_WRITE, 1, led_off=1)
    bus.send(C.LED_ERROR_WRITE, 1, mask=3)
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=300)  # not saved
    assert [p.name for p in tmp_path.iterdir()] == ["bus.json"]  # written atomically, no leftovers

    again = Bus([1, 2], state_path=state)
    assert again.read(C.ANGLE_OFFSET_READ, 1) == {"offset_units": 12}
    assert again.read(C.ANGLE_LIMIT_READ, 1) == {"min_units": 100, "max_units": 900}
    assert again.read(C.VIN_LIMIT_READ, 1) == {"min_mv": 5000, "max_mv": 9000}
    assert again.read(C.TEMP_MAX_LIMIT_READ, 1) == {"temp_c": 70}
    assert again.read(C.LED_CTRL_READ, 1) == {"led_off": 1}
    assert again.read(C.LED_ERROR_READ, 1) == {"mask": 3}
    assert again.read(C.OR_MOTOR_MODE_READ, 1) == {"mode": 0, "reserved": 0, "speed": 0}
    assert again.read(C.ID_READ, 7) == {"servo_id": 7}
    assert again.read(C.ID_READ, 2) is None


def test_a_missing_state_folder_is_refused_not_created(tmp_path):
    state = tmp_path / "emulators" / "bus.json"
    with pytest.raises(
        ChoreoError,
        match=r"emulator state .*bus.json: the folder .*emulators "
        "does not exist; create it",
    ):
        Bus([1], state_path=state)
    assert list(tmp_path.iterdir()) == []


def test_a_state_file_that_is_json_but_not_an_object_is_refused_in_one_line(tmp_path):
    state = tmp_path / "bus.json"
    state.write_text("[1, 2]\n")
    with pytest.raises(
        ChoreoError,
        match="bus.json: cannot read emulator state: not a "
        "choreo-emulator-state file: a JSON object is expected; delete it to start",
    ):
        Bus([1], state_path=state)


@pytest.mark.parametrize(
    "text, problem",
    [
        ("{\n  servos: 5\n", ":2:3: cannot read emulator state: not JSON; delete it"),
        (
            '{"format": "choreo-emulator-state", "version": 1, "servos": [{"model": "LX-16A"}]}',
            ": cannot read emulator state: not a choreo-emulator-state file of version 1 (a "
            "servo's entry is damaged); delete it",
        ),
    ],
)
def test_a_damaged_state_file_says_where_and_what_to_do_in_choreo_s_words(tmp_path, text, problem):
    state = tmp_path / "bus.json"
    state.write_text(text)
    with pytest.raises(ChoreoError) as refused:
        Bus([1], state_path=state)
    assert str(refused.value).startswith(f"{state}{problem}")


def test_a_state_path_that_is_a_folder_or_fifo_is_named_so(tmp_path):
    with fifo_that_never_blocks(tmp_path / "bus.json") as fifo:  # never opened: it would block
        with pytest.raises(
            ChoreoError, match=r"bus.json: cannot read emulator state: it is a FIFO"
        ):
            Bus([1], state_path=fifo)
    with pytest.raises(ChoreoError, match=r"cannot read emulator state: it is a folder"):
        Bus([1], state_path=tmp_path)


def test_a_state_file_for_other_servos_is_refused(tmp_path):
    state = tmp_path / "bus.json"
    Bus([1, 2], state_path=state).send(C.ID_WRITE, 1, new_id=3)
    with pytest.raises(ChoreoError, match="same servos or delete the file"):
        BusEmulator([1, 2, 3], clock=VirtualClock(), state_path=state)


def test_a_corrupt_state_file_is_reported_with_its_path(tmp_path):
    state = tmp_path / "bus.json"
    state.write_text("{not json")
    with pytest.raises(ChoreoError, match="bus.json"):
        BusEmulator([1], clock=VirtualClock(), state_path=state)


# --- faults -------------------------------------------------------------------------------------
def test_over_temperature_unloads_and_resumes_once_cooled(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=1000)
    bus.wait(0.2)
    servo = bus.emulator.servo(1)
    servo.temperature_c = 86  # TEMP_MAX is 85
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}
    assert servo.led_flashing
    stopped = bus.position()
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)  # refused while hot
    bus.wait(0.5)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}
    assert bus.position() == stopped
    servo.temperature_c = 60
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}
    assert not servo.led_flashing


def test_vin_outside_the_limits_unloads_and_stays_unloaded(bus):
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    servo = bus.emulator.servo(1)
    servo.vin_mv = 4400  # factory minimum 4500
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=100, time_ms=0)  # refused
    bus.wait(0.5)
    assert bus.position() == 500
    servo.vin_mv = 7400
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}


def test_narrowing_the_vin_limits_below_the_supply_unloads(bus):
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    bus.emulator.servo(1).vin_mv = 8000
    bus.send(C.VIN_LIMIT_WRITE, 1, min_mv=6000, max_mv=7500)
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}


def test_a_vanished_servo_hears_nothing_until_it_comes_back(bus):
    servo = bus.emulator.servo(1)
    servo.connected = False
    assert bus.raw_reply(C.POS_READ, 1) == b""
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=100, time_ms=0)
    bus.wait(0.5)
    servo.connected = True
    assert bus.position() == 500


# --- the wire log -------------------------------------------------------------------------------
def test_log_records_packets_with_arrival_times_and_moves(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=600, time_ms=400)
    bus.wait(0.02)
    bus.send(C.MOVE_STOP, 1)
    log = bus.emulator.log
    write, stop = log.packets
    assert write.packet.command is C.MOVE_TIME_WRITE and stop.packet.command is C.MOVE_STOP
    assert stop.time_s - write.time_s == pytest.approx(0.02 + 6 * BYTE_S)
    (move,) = log.moves
    assert (move.servo_id, move.from_units, move.to_units, move.duration_s) == (1, 500, 600, 0.4)


def test_bytes_another_thread_brought_in_are_due_now_not_never():
    """Reading the log delivers what is due, as every public method does: from another thread
    (a test watching the wire), between a pty bridge's take_received and its wait for the next
    event. The bridge must see those bytes due now: an infinite wait left them unsent until the
    host wrote again, after its read had timed out."""
    clock = VirtualClock()
    emulator = BusEmulator(clock=clock)
    emulator.write(encode_request(C.POS_READ, 1))
    assert emulator.take_received() == b""  # the bridge's take: nothing has arrived yet
    clock.advance(1.0)  # the request and its reply are over
    assert emulator.log.packets  # another thread's read: the reply's bytes now wait to be taken
    assert emulator.next_event_s() <= clock.now()
    assert emulator.take_received() == hexbytes("55 55 01 05 1C F4 01 E8")
    assert emulator.next_event_s() == float("inf")  # nothing more to come


@pytest.mark.parametrize(
    "option, value, words",
    [
        ("start_gap_s", float("nan"), "start_gap_s must be a number >= 0 s, got nan"),
        ("start_gap_s", -1, "start_gap_s must be a number >= 0 s, got -1"),
        ("turnaround_s", float("inf"), "turnaround_s must be a number >= 0 and <= 1 s, got inf"),
    ],
)
def test_an_emulator_timing_that_is_no_time_is_refused_by_name(option, value, words):
    with pytest.raises(OptionError) as refused:
        BusEmulator((1,), **{option: value})
    assert refused.value.option == option and str(refused.value) == words
