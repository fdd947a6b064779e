"""What an emulated servo keeps across power-off (its EEPROM), each value inside the range its write
command's field allows."""

from __future__ import annotations

from dataclasses import dataclass, fields

from choreo.bus.protocol import Command, ErrorMask, field_range

# EEPROM field -> its valid range: that of the write command's field (one source of truth: SPECS).
_EEPROM_RANGES: dict[str, tuple[int, int]] = {
    "servo_id": field_range(Command.ID_WRITE, "new_id"),
    "offset_units": field_range(Command.ANGLE_OFFSET_ADJUST, "offset_units"),
    "angle_min_units": field_range(Command.ANGLE_LIMIT_WRITE, "min_units"),
    "angle_max_units": field_range(Command.ANGLE_LIMIT_WRITE, "max_units"),
    "vin_min_mv": field_range(Command.VIN_LIMIT_WRITE, "min_mv"),
    "vin_max_mv": field_range(Command.VIN_LIMIT_WRITE, "max_mv"),
    "temp_max_c": field_range(Command.TEMP_MAX_LIMIT_WRITE, "temp_c"),
    "led_off": field_range(Command.LED_CTRL_WRITE, "led_off"),
    "error_mask": field_range(Command.LED_ERROR_WRITE, "mask"),
}


@dataclass(frozen=True)
class Eeprom:
    """What a servo keeps across power-off; factory values by default."""

    servo_id: int
    offset_units: int = 0
    angle_min_units: int = 0
    angle_max_units: int = 1000
    vin_min_mv: int = 4500
    vin_max_mv: int = 14000
    temp_max_c: int = 85
    led_off: int = 0  # 0 = LED on, as on the wire
    error_mask: int = int(ErrorMask.OVER_TEMPERATURE | ErrorMask.VOLTAGE | ErrorMask.STALLED)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            lo, hi = _EEPROM_RANGES[f.name]
            if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
                raise ValueError(f"{f.name} must be an integer in {lo}..{hi}, got {value!r}")
        for low, high in (("angle_min_units", "angle_max_units"), ("vin_min_mv", "vin_max_mv")):
            if getattr(self, low) >= getattr(self, high):
                raise ValueError(
                    f"{low} must be less than {high}, "
                    f"got {getattr(self, low)} >= {getattr(self, high)}"
                )
