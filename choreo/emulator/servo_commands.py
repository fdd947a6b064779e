"""An emulated servo's answer to each command: one method per command, and the table the servo
looks them up in (``EmulatedServo.handle``).

:class:`ServoCommands` is the half of :class:`~choreo.emulator.emulated_servo.EmulatedServo` that
speaks the protocol; the other half (its state, motion and faults) is what these methods act on.
The choices made where the real servo's behaviour is undocumented are listed in
``emulated_servo``'s docstring.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace
from typing import ClassVar

from choreo.bus.protocol import BYTE_TIME_S, Command
from choreo.bus.servo_models import DEG_PER_UNIT
from choreo.emulator.servo_motion import Motion

logger = logging.getLogger(__name__)

DIS_PULSES_PER_TURN = 4096


class ServoCommands:
    """One method per command: ``(self, at_s, packet, **request fields) -> reply fields``."""

    def _move_time_write(self, at_s, packet, *, pos_units, time_ms):
        self._move(at_s, pos_units, time_ms, Command.MOVE_TIME_WRITE)

    def _move_time_read(self, at_s, packet):
        pos_units, time_ms = self._last_move
        return dict(pos_units=pos_units, time_ms=time_ms)

    def _move_time_wait_write(self, at_s, packet, *, pos_units, time_ms):
        self._preset = (pos_units, time_ms)
        self._preset_end_s = at_s

    def _move_time_wait_read(self, at_s, packet):
        pos_units, time_ms = self._preset or (0, 0)
        return dict(pos_units=pos_units, time_ms=time_ms)

    def _move_start(self, at_s, packet):
        if self._preset is None:
            return
        first_byte_s = at_s - len(packet.encode()) * BYTE_TIME_S
        if first_byte_s - self._preset_end_s < self.start_gap_s:
            logger.debug(
                "servo %d missed MOVE_START sent too soon after its preset", self._eeprom.servo_id
            )
            return
        self._move(at_s, *self._preset, Command.MOVE_START)

    def _move_stop(self, at_s, packet):
        if self._loaded and not self._motor_mode:
            self._hold(at_s)

    def _id_write(self, at_s, packet, *, new_id):
        self._eeprom = replace(self._eeprom, servo_id=new_id)

    def _id_read(self, at_s, packet):
        return dict(servo_id=self._eeprom.servo_id)

    def _offset_adjust(self, at_s, packet, *, offset_units):
        self._offset_units = offset_units
        if self._loaded and not self._motor_mode:
            remaining_s = max(0.0, self._motion.end_s - at_s)
            self._drive_to(at_s, self._target_units, remaining_s, Command.ANGLE_OFFSET_ADJUST)

    def _offset_write(self, at_s, packet):
        self._eeprom = replace(self._eeprom, offset_units=self._offset_units)

    def _offset_read(self, at_s, packet):
        return dict(offset_units=self._offset_units)

    def _angle_limit_write(self, at_s, packet, *, min_units, max_units):
        self._eeprom = replace(self._eeprom, angle_min_units=min_units, angle_max_units=max_units)

    def _angle_limit_read(self, at_s, packet):
        return dict(min_units=self._eeprom.angle_min_units, max_units=self._eeprom.angle_max_units)

    def _vin_limit_write(self, at_s, packet, *, min_mv, max_mv):
        self._eeprom = replace(self._eeprom, vin_min_mv=min_mv, vin_max_mv=max_mv)
        self._update_faults(at_s)

    def _vin_limit_read(self, at_s, packet):
        return dict(min_mv=self._eeprom.vin_min_mv, max_mv=self._eeprom.vin_max_mv)

    def _temp_max_write(self, at_s, packet, *, temp_c):
        self._eeprom = replace(self._eeprom, temp_max_c=temp_c)
        self._update_faults(at_s)

    def _temp_max_read(self, at_s, packet):
        return dict(temp_c=self._eeprom.temp_max_c)

    def _temp_read(self, at_s, packet):
        return dict(temp_c=min(255, max(0, round(self._temp_c))))

    def _vin_read(self, at_s, packet):
        return dict(vin_mv=self._vin_mv)

    def _pos_read(self, at_s, packet):
        return dict(pos_units=round(self._reading_at(at_s)))

    def _motor_mode_write(self, at_s, packet, *, mode, reserved, speed):
        self._motor_speed = speed
        if mode == 1:
            self._motor_mode = True
            self._load(at_s)
            return
        if self._motor_mode:
            self._motor_mode = False
            reading = self._reading_at(at_s)
            self._set_motion(at_s, Motion(at_s, reading + self._offset_units))
        if self._loaded:
            self._hold(at_s)

    def _motor_mode_read(self, at_s, packet):
        return dict(mode=int(self._motor_mode), reserved=0, speed=self._motor_speed)

    def _load_write(self, at_s, packet, *, loaded):
        if loaded:
            self._load(at_s)
        else:
            self._resume_when_cool = False
            self._unload(at_s)

    def _load_read(self, at_s, packet):
        return dict(loaded=int(self._loaded))

    def _led_ctrl_write(self, at_s, packet, *, led_off):
        self._eeprom = replace(self._eeprom, led_off=led_off)

    def _led_ctrl_read(self, at_s, packet):
        return dict(led_off=self._eeprom.led_off)

    def _led_error_write(self, at_s, packet, *, mask):
        self._eeprom = replace(self._eeprom, error_mask=mask)

    def _led_error_read(self, at_s, packet):
        return dict(mask=self._eeprom.error_mask)

    def _dis_read(self, at_s, packet):
        travelled = self._travelled_units + abs(
            self._motion.output_at(at_s) - self._motion.start_units
        )
        pulses = round(travelled * DEG_PER_UNIT / 360 * DIS_PULSES_PER_TURN)
        return dict(distance=pulses & 0xFFFFFFFF)

    C = Command
    # Each handler takes (self, at_s, packet, **request fields) and returns the reply's fields,
    # or None when the command has no reply.
    _HANDLERS: ClassVar[dict[Command, Callable[..., dict[str, int] | None]]] = {
        C.MOVE_TIME_WRITE: _move_time_write,
        C.MOVE_TIME_READ: _move_time_read,
        C.MOVE_TIME_WAIT_WRITE: _move_time_wait_write,
        C.MOVE_TIME_WAIT_READ: _move_time_wait_read,
        C.MOVE_START: _move_start,
        C.MOVE_STOP: _move_stop,
        C.ID_WRITE: _id_write,
        C.ID_READ: _id_read,
        C.ANGLE_OFFSET_ADJUST: _offset_adjust,
        C.ANGLE_OFFSET_WRITE: _offset_write,
        C.ANGLE_OFFSET_READ: _offset_read,
        C.ANGLE_LIMIT_WRITE: _angle_limit_write,
        C.ANGLE_LIMIT_READ: _angle_limit_read,
        C.VIN_LIMIT_WRITE: _vin_limit_write,
        C.VIN_LIMIT_READ: _vin_limit_read,
        C.TEMP_MAX_LIMIT_WRITE: _temp_max_write,
        C.TEMP_MAX_LIMIT_READ: _temp_max_read,
        C.TEMP_READ: _temp_read,
        C.VIN_READ: _vin_read,
        C.POS_READ: _pos_read,
        C.OR_MOTOR_MODE_WRITE: _motor_mode_write,
        C.OR_MOTOR_MODE_READ: _motor_mode_read,
        C.LOAD_OR_UNLOAD_WRITE: _load_write,
        C.LOAD_OR_UNLOAD_READ: _load_read,
        C.LED_CTRL_WRITE: _led_ctrl_write,
        C.LED_CTRL_READ: _led_ctrl_read,
        C.LED_ERROR_WRITE: _led_error_write,
        C.LED_ERROR_READ: _led_error_read,
        C.DIS_READ: _dis_read,
    }
    del C
