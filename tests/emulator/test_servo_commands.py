"""An emulated servo's answer to each command, driven by raw packets on a virtual clock.

Golden reply bytes come from the verified packets of docs/protocol.md."""

from __future__ import annotations

import pytest
from emulator_helpers import Bus, hexbytes

from choreo.bus.protocol import (
    BROADCAST_ID,
    encode_packet,
    encode_request,
)
from choreo.bus.protocol import (
    Command as C,
)
from choreo.emulator import ServoSpec


# --- every read command -------------------------------------------------------------------------
@pytest.mark.parametrize(
    "command, reply",
    [
        (C.ID_READ, "55 55 01 04 0E 01 EB"),
        (C.ANGLE_LIMIT_READ, "55 55 01 07 15 00 00 E8 03 F7"),
        (C.VIN_LIMIT_READ, "55 55 01 07 17 94 11 B0 36 55"),
        (C.TEMP_MAX_LIMIT_READ, "55 55 01 04 19 55 8C"),
        (C.POS_READ, "55 55 01 05 1C F4 01 E8"),
        (C.LED_CTRL_READ, "55 55 01 04 22 00 D8"),
        (C.LED_ERROR_READ, "55 55 01 04 24 07 CF"),
        (C.OR_MOTOR_MODE_READ, "55 55 01 07 1E 00 00 00 00 D9"),
        (C.LOAD_OR_UNLOAD_READ, "55 55 01 04 20 00 DA"),
        (C.ANGLE_OFFSET_READ, "55 55 01 04 13 00 E7"),
    ],
)
def test_factory_servo_answers_reads_with_the_documented_bytes(bus, command, reply):
    assert bus.raw_reply(command, 1) == hexbytes(reply)


def test_temperature_and_vin_reads_report_what_the_test_set(bus):
    servo = bus.emulator.servo(1)
    servo.temperature_c = 31
    servo.vin_mv = 7400
    assert bus.raw_reply(C.TEMP_READ, 1) == hexbytes("55 55 01 04 1A 1F C1")
    assert bus.raw_reply(C.VIN_READ, 1) == hexbytes("55 55 01 05 1B E8 1C DA")


def test_move_time_read_reports_the_last_commanded_move(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=500, time_ms=1000)
    assert bus.raw_reply(C.MOVE_TIME_READ, 1) == hexbytes("55 55 01 07 02 F4 01 E8 03 15")


def test_wait_read_reports_the_preset_on_models_that_answer_it():
    bus = Bus([ServoSpec(2, "LX-224HV")])
    bus.send(C.MOVE_TIME_WAIT_WRITE, 2, pos_units=300, time_ms=500)
    assert bus.raw_reply(C.MOVE_TIME_WAIT_READ, 2) == hexbytes("55 55 02 07 08 2C 01 F4 01 CC")


def test_motor_mode_read_reports_mode_and_speed(bus):
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=-500)
    assert bus.raw_reply(C.OR_MOTOR_MODE_READ, 1) == hexbytes("55 55 01 07 1E 01 00 0C FE CE")


def test_lx16a_does_not_answer_wait_read_or_distance_read(bus):
    bus.send(C.MOVE_TIME_WAIT_WRITE, 1, pos_units=300, time_ms=500)
    assert bus.raw_reply(C.MOVE_TIME_WAIT_READ, 1) == b""
    assert bus.raw_reply(C.DIS_READ, 1) == b""
    assert bus.position() == 500  # it is there; it just doesn't answer those two


def test_distance_read_counts_travel_both_ways_at_4096_pulses_per_turn():
    bus = Bus([ServoSpec(1, "LX-224HV")])
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=0)
    bus.wait(1.0)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=0)
    bus.wait(1.0)
    # 500 + 1000 units = 360° = exactly one turn
    assert bus.read(C.DIS_READ) == {"distance": 4096}


def test_id_write_renumbers_one_servo(bus):
    bus.send(C.ID_WRITE, 1, new_id=5)
    assert bus.raw_reply(C.ID_READ, 5) == hexbytes("55 55 05 04 0E 05 E3")
    assert bus.raw_reply(C.POS_READ, 1) == b""


def test_writes_out_of_range_are_ignored(bus):
    bus.port.write(encode_packet(1, C.ANGLE_LIMIT_WRITE, bytes.fromhex("8403 6400")))  # 900 > 100
    bus.port.write(encode_packet(1, C.TEMP_MAX_LIMIT_WRITE, bytes((40,))))  # below 50
    bus.port.write(
        encode_packet(1, C.ANGLE_OFFSET_ADJUST, (-126).to_bytes(1, "little", signed=True))
    )
    assert bus.read(C.ANGLE_LIMIT_READ) == {"min_units": 0, "max_units": 1000}
    assert bus.read(C.TEMP_MAX_LIMIT_READ) == {"temp_c": 85}
    assert bus.read(C.ANGLE_OFFSET_READ) == {"offset_units": 0}


# --- staged moves -------------------------------------------------------------------------------
def test_staged_move_waits_for_start_by_own_id(bus):
    bus.send(C.MOVE_TIME_WAIT_WRITE, 1, pos_units=300, time_ms=0)
    bus.wait(0.5)
    assert bus.position() == 500
    bus.send(C.MOVE_START, 1)
    bus.wait(0.5)
    assert bus.position() == 300
    assert bus.emulator.log.moves[-1].command is C.MOVE_START


def test_preset_survives_start_so_start_again_reruns_it(bus):
    bus.send(C.MOVE_TIME_WAIT_WRITE, 1, pos_units=300, time_ms=0)
    bus.wait(0.01)
    bus.send(C.MOVE_START, 1)
    bus.wait(0.5)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=800, time_ms=0)
    bus.wait(0.5)
    assert bus.position() == 800
    bus.send(C.MOVE_START, BROADCAST_ID)
    bus.wait(0.5)
    assert bus.position() == 300


def test_start_without_a_preset_is_ignored(bus):
    bus.send(C.MOVE_START, 1)
    bus.send(C.MOVE_START, BROADCAST_ID)
    bus.wait(0.5)
    assert len(bus.emulator.log.moves) == 0
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 0}


@pytest.mark.parametrize(
    "options,expected",
    [({}, 300), ({"start_gap_s": 0.0}, 300), ({"start_gap_s": 0.001}, 500)],
    ids=["default-off", "off", "fault-1ms"],
)
def test_start_right_after_the_preset_is_missed_only_with_the_gap_fault(options, expected):
    # Real servos take a back-to-back START (third-party drivers rely on it); that they *can*
    # miss one is a fault to switch on, checking that a host leaves the gap.
    bus = Bus(**options)
    bus.port.write(encode_request(C.MOVE_TIME_WAIT_WRITE, 1, pos_units=300, time_ms=0))
    bus.port.write(encode_request(C.MOVE_START, 1))  # back to back: no gap
    bus.wait(0.5)
    assert bus.position() == expected


# --- stop, load, motor mode ---------------------------------------------------------------------
def test_move_stop_freezes_the_servo_where_it_is(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=1000)
    bus.wait(0.2)
    bus.send(C.MOVE_STOP, 1)
    stopped_at = bus.emulator.servo(1).position_units
    assert stopped_at == pytest.approx(600, abs=1)
    bus.wait(1.0)
    assert bus.emulator.servo(1).position_units == stopped_at
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}


def test_moves_are_ignored_in_motor_mode_and_servo_mode_holds_again(bus):
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=0)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=100, time_ms=0)
    bus.wait(0.5)
    assert bus.position() == 500
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=0, reserved=0, speed=0)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=100, time_ms=0)
    bus.wait(0.5)
    assert bus.position() == 100


# --- offsets ------------------------------------------------------------------------------------
def test_offset_adjust_moves_the_output_at_once_and_reads_stay_in_the_command_frame(bus):
    bus.send(C.LOAD_OR_UNLOAD_WRITE, 1, loaded=1)
    bus.send(C.ANGLE_OFFSET_ADJUST, 1, offset_units=-10)
    assert bus.raw_reply(C.ANGLE_OFFSET_READ, 1) == hexbytes("55 55 01 04 13 F6 F1")
    bus.wait(0.1)
    servo = bus.emulator.servo(1)
    assert servo.output_units == pytest.approx(490)
    assert bus.position() == 500
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=200, time_ms=0)
    bus.wait(0.5)
    assert servo.output_units == pytest.approx(190)


def test_offset_on_an_unloaded_servo_shifts_the_reading_only(bus):
    bus.send(C.ANGLE_OFFSET_ADJUST, 1, offset_units=25)
    assert bus.emulator.servo(1).output_units == 500
    assert bus.position() == 475


def test_offset_is_saved_only_by_offset_write(bus):
    bus.send(C.ANGLE_OFFSET_ADJUST, 1, offset_units=-10)
    assert bus.emulator.servo(1).eeprom.offset_units == 0
    bus.send(C.ANGLE_OFFSET_WRITE, 1)
    assert bus.emulator.servo(1).eeprom.offset_units == -10
