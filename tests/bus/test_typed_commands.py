"""Each command as a typed method, and a servo's every readable parameter at once, against the
emulator."""

from __future__ import annotations

from servo_bus_helpers import make_bus

from choreo.bus.protocol import ErrorMask
from choreo.bus.typed_commands import AngleLimits, MotorMode, MoveTime, VinLimits


def test_every_read_command(bus_and_emulator):
    bus, emulator = bus_and_emulator
    bus.set_angle_limits(2, 100, 900)
    bus.set_vin_limits(2, 5000, 12000)
    bus.set_temp_limit(2, 70)
    bus.adjust_offset(2, -10)
    bus.set_led(2, False)
    bus.set_led_errors(2, ErrorMask.OVER_TEMPERATURE | ErrorMask.STALLED)
    bus.stage_move(2, 300, 500)
    bus.move(2, 700, 200)
    emulator.servo(2).temperature_c = 41
    emulator.servo(2).vin_mv = 11100
    emulator.clock.advance(1.0)

    assert bus.read_position(2) == 700
    assert bus.read_move(2) == MoveTime(700, 200)
    assert bus.read_staged_move(2) == MoveTime(300, 500)
    assert bus.read_id(2) == 2
    assert bus.read_offset(2) == -10
    assert bus.read_angle_limits(2) == AngleLimits(100, 900)
    assert bus.read_vin_limits(2) == VinLimits(5000, 12000)
    assert bus.read_temp_limit(2) == 70
    assert bus.read_temperature(2) == 41
    assert bus.read_vin(2) == 11100
    assert bus.read_mode(2) == MotorMode(motor=False, speed=0)
    assert bus.read_loaded(2) is True  # a move loads the servo
    assert bus.read_led(2) is False
    assert bus.read_led_errors(2) == ErrorMask.OVER_TEMPERATURE | ErrorMask.STALLED
    assert isinstance(bus.read_distance(2), int)
    bus.set_motor_mode(2, -300)
    assert bus.read_mode(2) == MotorMode(motor=True, speed=-300)
    bus.unload(2)
    assert bus.read_loaded(2) is False


def test_an_adjusted_offset_is_kept_only_once_saved():
    bus, emulator = make_bus()
    bus.adjust_offset(1, -10)
    assert emulator.servo(1).eeprom.offset_units == 0
    bus.save_offset(1)
    assert bus.read_offset(1) == -10
    assert emulator.servo(1).eeprom.offset_units == -10


def test_set_id_renumbers_one_servo():
    bus, emulator = make_bus()
    bus.set_id(2, 12)
    assert bus.scan(range(0, 16)) == [1, 3, 12]


def test_lx16a_does_not_answer_wait_read_and_info_says_so():
    bus, _ = make_bus(model="LX-16A")
    info = bus.read_info(1)
    assert info.staged_move is None and info.distance is None
    assert info.pos_units == 500 and info.angle_limits == AngleLimits(0, 1000)
