"""One emulated LX bus servo: its state, its motion and its faults; its answer to each command is
``servo_commands``, what it keeps across power-off ``eeprom``, how its horn moves and reads
``servo_motion``, and faults injected into its replies ``reply_faults``.

Behaviour follows ``docs/protocol.md`` ("What a servo does"). Choices made where the
servo's behaviour is undocumented:

- **Positions and the offset.** The servo has an *output* position (where the horn really is, in
  units of 0.24°) and reports ``POS_READ = output - offset``: readings are in the frame the host
  commands in. A target ``pos`` drives the output to ``pos + offset``. So OFFSET_ADJUST by +10 on a
  servo holding 500 moves the horn to 510 and it still reads 500; on an unloaded servo nothing moves
  and the reading drops by 10. ``move_by_hand`` takes a position in the reading frame.
- OFFSET_ADJUST on a loaded servo in servo mode re-aims the current move at ``target + offset``,
  finishing when the move would have finished (at once if it had), capped by the top speed.
- MOVE_TIME_READ reports the last commanded target *after* clamping to the angle limits, with the
  time as sent. MOVE_TIME_WAIT_READ reports the preset as sent (clamping happens at START), or
  ``(0, 0)`` if there is none.
- Moves (MOVE_TIME_WRITE, MOVE_START) are ignored in motor mode; presets are still stored.
- OR_MOTOR_MODE_WRITE with mode 1 loads the servo, like a move. Switching back to servo mode holds
  the current (wrapped) position.
- Motor speed ``s`` turns the output at ``s / 1000`` of the no-load speed. Readings wrap with 1500
  counts per turn into -250..1249 (1500 × 0.24° = 360°); the ~30° band of garbage is not modelled.
- Faults: above TEMP_MAX or with VIN outside the limits the motor unloads and refuses to load.
  After over-temperature it re-loads by itself once cooled (holding where it is, or turning again
  in motor mode); after a voltage fault it stays unloaded until a LOAD or a move.
- Writes with a parameter outside its documented range are ignored (the servo cannot answer NAK),
  except positions, which are clamped to the angle limits like any other target.
- The START gap is a fault, off by default (``start_gap_s`` 0): docs/protocol.md says only that a
  MOVE_START sent right after the preset *can* be missed, and drivers that stage and start back
  to back work on real servos. With ``start_gap_s`` > 0, a MOVE_START whose first byte comes less
  than that after the end of the servo's own MOVE_TIME_WAIT_WRITE is missed, to check that a
  host leaves the gap (choreo's player does: ``start_gap_ms=1`` in ``sim://``).
- DIS_READ (models that answer it) reports the distance the output has travelled since power-up,
  forwards and backwards alike, at 4096 pulses per turn.
- **With a physical world** (``physics``, see ``physics.py``) the motion above is the servo's
  set-point, not its horn: POS_READ, VIN_READ and TEMP_READ report what the world says, a hold
  (MOVE_STOP, LOAD, unloading) holds where the horn really is, and a move after the servo was
  unloaded starts from there. Its temperature and supply also raise its faults. Moving it by hand
  is the world's business: ``move_by_hand`` is refused.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

from choreo.bus.protocol import (
    BROADCAST_ID,
    SPECS,
    Command,
    ErrorMask,
    Packet,
    decode_request,
    encode_reply,
)
from choreo.bus.servo_models import UNITS_PER_DEG, ServoModel
from choreo.emulator.eeprom import Eeprom
from choreo.emulator.physics import ServoPhysics
from choreo.emulator.reply_faults import ReplyFate, ReplyFaults
from choreo.emulator.servo_commands import ServoCommands
from choreo.emulator.servo_motion import Motion, check_readable, wrap_reading

logger = logging.getLogger(__name__)

FACTORY_TEMP_C = 30.0
DEFAULT_START_GAP_S = 0.0  # off: a START right after its preset is taken (see the docstring)


@dataclass(frozen=True)
class StartedMove:
    """A servo-mode move began: logged by the bus for tests of timing and synchronization."""

    time_s: float
    servo_id: int
    from_units: float  # reading frame (POS_READ)
    to_units: float  # the target after clamping, reading frame
    duration_s: float  # after the speed cap
    command: Command  # MOVE_TIME_WRITE, MOVE_START or ANGLE_OFFSET_ADJUST


@dataclass(frozen=True)
class HandledPacket:
    """What handling one packet produced: the reply bytes (if any), the moves started, and the
    EEPROM afterwards (for the bus to persist)."""

    eeprom: Eeprom
    reply: bytes | None = None
    moves: tuple[StartedMove, ...] = ()


def _at_now(method):
    """Run a public method under the bus lock at ``now()``, after every due packet has acted."""

    @functools.wraps(method)
    def at_now(self, *args):
        with self._lock:
            return method(self, self._now(), *args)

    return at_now


class EmulatedServo(ServoCommands):
    """One servo. The bus calls :meth:`hears` and :meth:`handle` at each packet's arrival time.

    The public properties and methods (for tests and users) act at ``now()`` under ``lock``; the
    bus passes its lock and a ``now`` that first delivers every packet that has fully arrived, so
    they see the bus as it is.
    """

    def __init__(
        self,
        model: ServoModel,
        eeprom: Eeprom,
        now: Callable[[], float],
        *,
        lock: threading.RLock | None = None,
        position_units: float = 500.0,
        start_gap_s: float = DEFAULT_START_GAP_S,
        physics: ServoPhysics | None = None,
        loaded: bool = False,
    ):
        check_readable(position_units)
        self.model = model
        self._physics = physics
        self.start_gap_s = start_gap_s
        self._eeprom = eeprom
        self._now = now
        self._lock = lock if lock is not None else threading.RLock()
        self._connected = True
        self._reply_faults = ReplyFaults()
        self._offset_units = eeprom.offset_units
        self._vin_mv = round(sum(model.vin_range_mv) / 2)
        self._temp_c = FACTORY_TEMP_C
        self._loaded = loaded
        self._motor_mode = False
        self._motor_speed = 0
        self._preset: tuple[int, int] | None = None
        self._preset_end_s = -math.inf
        self._target_units = float(position_units)
        # MOVE_TIME_READ before any move: as if the servo had been commanded to where it is.
        self._last_move = (self._clamp_to_limits(round(position_units)), 0)
        self._resume_when_cool = False
        self._travelled_units = 0.0
        self._motion = Motion(now(), position_units + self._offset_units)
        self._moves_started: list[StartedMove] = []

    # --- what tests and users see ----------------------------------------------------------
    @property
    @_at_now
    def servo_id(self, now) -> int:
        return self._eeprom.servo_id

    @property
    @_at_now
    def eeprom(self, now) -> Eeprom:
        """The values kept across power-off (as saved, e.g. the offset before OFFSET_WRITE)."""
        return self._eeprom

    @property
    @_at_now
    def position_units(self, now) -> float:
        """What POS_READ reports (before rounding): output minus offset, wrapped."""
        return self._reading_at(now)

    @property
    @_at_now
    def output_units(self, now) -> float:
        """Where the horn really is (no offset, not wrapped)."""
        return self._output_at(now)

    @property
    @_at_now
    def offset_units(self, now) -> int:
        """The offset in use (EEPROM holds the saved one)."""
        return self._offset_units

    @property
    @_at_now
    def loaded(self, now) -> bool:
        return self._loaded

    @property
    @_at_now
    def motor_mode(self, now) -> bool:
        return self._motor_mode

    @property
    @_at_now
    def faults(self, now) -> ErrorMask:
        """Faults present now: over-temperature, voltage out of the limits."""
        return self._faults()

    @property
    @_at_now
    def led_flashing(self, now) -> bool:
        """The LED flashes for the faults present that the error mask enables."""
        return bool(self._faults() & self._eeprom.error_mask)

    @property
    @_at_now
    def connected(self, now) -> bool:
        """False: the servo hears nothing and answers nothing (a loose wire), keeping its state."""
        return self._connected

    @connected.setter
    @_at_now
    def connected(self, now, connected: bool) -> None:
        self._connected = connected

    @property
    @_at_now
    def reply_faults(self, now) -> ReplyFaults:
        """Faults to inject into this servo's replies from now on."""
        return self._reply_faults

    @reply_faults.setter
    @_at_now
    def reply_faults(self, now, faults: ReplyFaults) -> None:
        self._reply_faults = faults

    @property
    @_at_now
    def temperature_c(self, now) -> float:
        self._sense(now)
        return self._temp_c

    @temperature_c.setter
    @_at_now
    def temperature_c(self, now, temp_c: float) -> None:
        if not 0 <= temp_c <= 255:
            raise ValueError(
                f"temperature_c must be in 0..255 (one byte on the wire), got {temp_c}"
            )
        self._temp_c = temp_c
        self._update_faults(now)

    @property
    @_at_now
    def vin_mv(self, now) -> int:
        self._sense(now)
        return self._vin_mv

    @vin_mv.setter
    @_at_now
    def vin_mv(self, now, vin_mv: int) -> None:
        if not 0 <= vin_mv <= 0xFFFF:
            raise ValueError(f"vin_mv must be in 0..65535 (two bytes on the wire), got {vin_mv}")
        self._vin_mv = vin_mv
        self._update_faults(now)

    @_at_now
    def move_by_hand(self, now, pos_units: float) -> None:
        """Turn the horn of an unloaded servo so that it reads ``pos_units`` (teach mode)."""
        check_readable(pos_units)
        if self._physics is not None:
            raise ValueError(
                f"servo {self._eeprom.servo_id} stands in a physical world: its horn goes where "
                "the physics puts it"
            )
        if self._loaded:
            raise ValueError(
                f"servo {self._eeprom.servo_id} is loaded (holding torque): "
                f"unload it before moving it by hand"
            )
        self._set_motion(now, Motion(now, pos_units + self._offset_units))

    # --- the bus side ----------------------------------------------------------------------
    def take_reply_fault(self, draw: Callable[[], float]) -> ReplyFate:
        """The fate of the reply being sent (SENT, DROPPED or CORRUPTED); ``draw`` gives a
        uniform random number in [0, 1) from the bus's seeded generator."""
        fate, self._reply_faults = self._reply_faults.take(draw)
        return fate

    def hears(self, packet: Packet) -> bool:
        return self._connected and packet.servo_id in (self._eeprom.servo_id, BROADCAST_ID)

    def handle(self, packet: Packet, at_s: float) -> HandledPacket:
        """Execute ``packet`` (already known to be heard) whose last byte arrived at ``at_s``."""
        self._sense(at_s)
        try:
            command = Command(packet.command)
            values = decode_request(packet)
        except ValueError as error:
            logger.debug("servo %d ignores %s: %s", self._eeprom.servo_id, packet, error)
            return HandledPacket(self._eeprom)
        if not self._in_range(command, values):
            logger.debug(
                "servo %d ignores %s %s: out of range", self._eeprom.servo_id, command.name, values
            )
            return HandledPacket(self._eeprom)
        reply_values = self._HANDLERS[command](self, at_s, packet, **values)
        moves, self._moves_started = tuple(self._moves_started), []
        if reply_values is None or not self._answers(command, packet):
            return HandledPacket(self._eeprom, None, moves)
        reply = encode_reply(command, self._eeprom.servo_id, **reply_values)
        return HandledPacket(self._eeprom, reply, moves)

    def _answers(self, command: Command, packet: Packet) -> bool:
        if packet.servo_id == BROADCAST_ID and command is not Command.ID_READ:
            return False
        if command is Command.MOVE_TIME_WAIT_READ:
            return self.model.answers_wait_read
        if command is Command.DIS_READ:
            return self.model.answers_dis_read
        return True

    @staticmethod
    def _in_range(command: Command, values: dict[str, int]) -> bool:
        spec = SPECS[command]
        for f in spec.request:
            if f.name != "pos_units" and not f.lo <= values[f.name] <= f.hi:
                return False
        return (
            spec.ordered_pair is None or values[spec.ordered_pair[0]] < values[spec.ordered_pair[1]]
        )

    # --- motion ----------------------------------------------------------------------------
    @property
    def _top_speed_units_s(self) -> float:
        return self.model.no_load_speed_deg_s * UNITS_PER_DEG

    def _output_at(self, time_s: float) -> float:
        """Where the horn is: the servo's own motion, or the world's answer."""
        if self._physics is not None:
            return self._physics.output_units(time_s)
        return self._motion.output_at(time_s)

    def _reading_at(self, time_s: float) -> float:
        return wrap_reading(self._output_at(time_s) - self._offset_units)

    def _sense(self, now: float) -> None:
        """Take the world's supply and temperature (their faults act at once)."""
        if self._physics is None:
            return
        vin_mv, temp_c = self._physics.vin_mv(now), self._physics.temp_c(now)
        if (vin_mv, temp_c) != (self._vin_mv, self._temp_c):
            self._vin_mv, self._temp_c = vin_mv, temp_c
            self._update_faults(now)

    def _set_motion(self, now: float, motion: Motion) -> None:
        self._travelled_units += abs(self._motion.output_at(now) - self._motion.start_units)
        self._travelled_units += abs(motion.start_units - self._motion.output_at(now))
        self._motion = motion
        if self._physics is not None:
            self._physics.drive(now, motion, self._loaded)

    def _hold(self, now: float) -> None:
        """Stand still where the output is now (held if loaded, resting if not)."""
        output = self._output_at(now)
        self._target_units = output - self._offset_units
        self._set_motion(now, Motion(now, output))

    def _spin(self, now: float) -> None:
        velocity = self._motor_speed / 1000 * self._top_speed_units_s
        self._set_motion(now, Motion(now, self._motion.output_at(now), velocity, math.inf))

    def _drive_to(self, now: float, target_units: float, time_s: float, command: Command) -> None:
        """Uniform move of the output to ``target_units + offset``, no faster than the top speed."""
        start = self._motion.output_at(now)
        distance = target_units + self._offset_units - start
        duration_s = max(time_s, abs(distance) / self._top_speed_units_s)
        velocity = distance / duration_s if duration_s > 0 else 0.0
        self._target_units = target_units
        self._set_motion(now, Motion(now, start, velocity, now + duration_s))
        self._moves_started.append(
            StartedMove(
                now,
                self._eeprom.servo_id,
                start - self._offset_units,
                target_units,
                duration_s,
                command,
            )
        )

    def _faults(self) -> ErrorMask:
        faults = ErrorMask.NONE
        if self._temp_c > self._eeprom.temp_max_c:
            faults |= ErrorMask.OVER_TEMPERATURE
        if not self._eeprom.vin_min_mv <= self._vin_mv <= self._eeprom.vin_max_mv:
            faults |= ErrorMask.VOLTAGE
        return faults

    def _clamp_to_limits(self, pos_units: int) -> int:
        return min(max(pos_units, self._eeprom.angle_min_units), self._eeprom.angle_max_units)

    def _move(self, now: float, pos_units: int, time_ms: int, command: Command) -> None:
        if self._motor_mode:
            return
        target = self._clamp_to_limits(pos_units)
        self._last_move = (target, time_ms)
        if self._faults():
            return
        if self._physics is not None and not self._loaded:
            self._hold(now)  # an unloaded horn has gone where the world put it: start there
        self._loaded = True
        self._drive_to(now, target, time_ms / 1000, command)

    def _load(self, now: float) -> None:
        if self._faults():
            return
        self._loaded = True
        if self._motor_mode:
            self._spin(now)
        else:
            self._hold(now)

    def _unload(self, now: float) -> None:
        self._loaded = False
        self._hold(now)

    def _update_faults(self, now: float) -> None:
        faults = self._faults()
        if faults:
            if self._loaded:
                self._unload(now)
                self._resume_when_cool = faults == ErrorMask.OVER_TEMPERATURE
            elif ErrorMask.VOLTAGE in faults:
                self._resume_when_cool = False
        elif self._resume_when_cool:
            self._resume_when_cool = False
            self._load(now)
