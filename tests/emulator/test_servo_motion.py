"""How an emulated servo's horn moves and how its reading wraps: speeds and times from
docs/servo-models.md (LX-16A: 0.16 s/60°, so 240° = 1000 units take 0.64 s)."""

from __future__ import annotations

import pytest
from emulator_helpers import LX16A_FULL_SWING_S, Bus

from choreo.bus.protocol import (
    Command as C,
)
from choreo.emulator import ServoSpec
from choreo.emulator.servo_motion import Motion, check_readable, wrap_reading


# --- moves --------------------------------------------------------------------------------------
def test_move_is_linear_at_uniform_speed(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=700, time_ms=1000)
    start = bus.emulator.log.moves[-1].time_s
    bus.clock.sleep_until(start + 0.25)
    assert bus.emulator.servo(1).position_units == pytest.approx(550)
    bus.clock.sleep_until(start + 0.75)
    assert bus.emulator.servo(1).position_units == pytest.approx(650)
    bus.clock.sleep_until(start + 2.0)
    assert bus.position() == 700


def test_move_time_is_capped_by_the_model_top_speed(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=0)
    bus.wait(1.0)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=100)  # faster than the motor can
    move = bus.emulator.log.moves[-1]
    assert move.duration_s == pytest.approx(LX16A_FULL_SWING_S)
    bus.clock.sleep_until(move.time_s + LX16A_FULL_SWING_S / 2)
    assert bus.emulator.servo(1).position_units == pytest.approx(500)


def test_slower_models_take_longer_for_the_same_swing():
    bus = Bus([ServoSpec(1, "LX-824HV", position_units=0)])
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=0)
    assert bus.emulator.log.moves[-1].duration_s == pytest.approx(0.20 * 240 / 60)


def test_a_new_move_restarts_from_where_the_servo_is(bus):
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=1000, time_ms=1000)
    bus.wait(0.5)
    bus.send(C.MOVE_TIME_WRITE, 1, pos_units=0, time_ms=1000)
    second = bus.emulator.log.moves[-1]
    assert second.from_units == pytest.approx(750, abs=1)
    bus.clock.sleep_until(second.time_s + 0.5)
    assert bus.emulator.servo(1).position_units == pytest.approx(second.from_units / 2)


def test_motor_mode_turns_at_a_speed_proportional_to_duty_and_wraps(bus):
    top_units_s = 375 * 1000 / 240
    bus.send(C.OR_MOTOR_MODE_WRITE, 1, mode=1, reserved=0, speed=400)
    start = bus.emulator.log.packets[-1].time_s
    bus.clock.sleep_until(start + 1.0)
    output = bus.emulator.servo(1).output_units
    assert output == pytest.approx(500 + 0.4 * top_units_s)  # 1125
    assert bus.read(C.LOAD_OR_UNLOAD_READ) == {"loaded": 1}
    bus.clock.sleep_until(start + 2.0)  # output 1750: one turn (1500 counts) past 250
    assert bus.emulator.servo(1).position_units == pytest.approx(250)


def test_a_reading_wraps_into_one_turn_of_1500_counts_from_minus_250():
    assert [wrap_reading(u) for u in (-250, 1249, 1250, -251, 500 + 3 * 1500)] == [
        -250,
        1249,
        -250,
        1249,
        500,
    ]


def test_a_motion_moves_uniformly_and_stops_at_its_end():
    motion = Motion(start_s=1.0, start_units=100.0, velocity_units_s=50.0, end_s=3.0)
    assert [motion.output_at(t) for t in (0.0, 1.0, 2.0, 3.0, 9.0)] == [100, 100, 150, 200, 200]


def test_a_position_outside_one_turn_is_refused_with_the_readable_range():
    check_readable(1249)
    with pytest.raises(ValueError, match=r"pos_units must be in -250\.\.1249 .*got 1250"):
        check_readable(1250)
