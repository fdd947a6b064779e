"""What an emulated servo keeps across power-off: factory values, each inside the range of the
write command's field."""

from __future__ import annotations

import re

import pytest

from choreo.bus.protocol import ErrorMask
from choreo.emulator.eeprom import Eeprom


def test_the_factory_values_are_those_of_a_new_servo():
    eeprom = Eeprom(3)
    assert (eeprom.servo_id, eeprom.offset_units, eeprom.angle_min_units) == (3, 0, 0)
    assert (eeprom.angle_max_units, eeprom.vin_min_mv, eeprom.vin_max_mv) == (1000, 4500, 14000)
    assert (eeprom.temp_max_c, eeprom.led_off) == (85, 0)
    assert eeprom.error_mask == ErrorMask.OVER_TEMPERATURE | ErrorMask.VOLTAGE | ErrorMask.STALLED


@pytest.mark.parametrize(
    "fields, words",
    [
        (dict(servo_id=254), "servo_id must be an integer in 0..253, got 254"),
        (dict(servo_id=1, offset_units=200), "offset_units must be an integer in -125..125"),
        (dict(servo_id=1, temp_max_c=True), "temp_max_c must be an integer in 50..100, got True"),
        (
            dict(servo_id=1, angle_min_units=600, angle_max_units=400),
            "angle_min_units must be less than angle_max_units, got 600 >= 400",
        ),
        (
            dict(servo_id=1, vin_min_mv=9000, vin_max_mv=9000),
            "vin_min_mv must be less than vin_max_mv, got 9000 >= 9000",
        ),
    ],
)
def test_a_value_the_write_command_could_not_carry_is_refused_by_name(fields, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        Eeprom(**fields)
