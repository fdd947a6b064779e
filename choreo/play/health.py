"""Health reads during a play: one servo's position, supply or temperature at a time, in the bus
time left before the next START, each checked against what preflight read and the plan.

Positions are read most often; each round over the servos also reads one servo's supply and
temperature. A read that goes unanswered is noise; ``max_missed_reads`` in a row from one servo
abort the play (``PlaybackAborted``), as do a servo too hot, a supply outside its limits or a
servo too far from where the plan has it.
"""

from __future__ import annotations

import enum
import logging
from dataclasses import dataclass
from typing import TypeVar

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.errors import BusTimeoutError, PlaybackAborted, ProtocolError, ServoFault
from choreo.play.play_options import PlayOptions
from choreo.play.preflight import ServoLimits, names
from choreo.robot.types import Joint, Robot

log = logging.getLogger(__name__)
N = TypeVar("N", int, float)


class Reading(enum.Enum):
    """A health read: its command and reply field."""

    POSITION = (Command.POS_READ, "pos_units")
    VIN = (Command.VIN_READ, "vin_mv")
    TEMPERATURE = (Command.TEMP_READ, "temp_c")


@dataclass
class ServoHealth:
    """Extremes of what the health reads saw on one servo (None: never read)."""

    joint: str
    servo_id: int
    temp_c_min: int | None = None
    temp_c_max: int | None = None
    vin_mv_min: int | None = None
    vin_mv_max: int | None = None
    position_error_deg_max: float | None = None
    reads: int = 0
    missed_reads: int = 0  # in a row, reset by an answer
    missed_total: int = 0  # in the whole play

    def saw_temperature(self, temp_c: int) -> None:
        self.temp_c_min = _lower(self.temp_c_min, temp_c)
        self.temp_c_max = _higher(self.temp_c_max, temp_c)

    def saw_vin(self, vin_mv: int) -> None:
        self.vin_mv_min = _lower(self.vin_mv_min, vin_mv)
        self.vin_mv_max = _higher(self.vin_mv_max, vin_mv)

    def saw_position_error(self, error_deg: float) -> None:
        self.position_error_deg_max = _higher(self.position_error_deg_max, error_deg)


def _lower(seen: N | None, value: N) -> N:
    return value if seen is None else min(seen, value)


def _higher(seen: N | None, value: N) -> N:
    return value if seen is None else max(seen, value)


class HealthReads:
    """The health reads of one player: which servo to read next, and what they saw
    (``records``, one :class:`ServoHealth` per joint)."""

    def __init__(
        self, bus: ServoBus, robot: Robot, limits: dict[str, ServoLimits], options: PlayOptions
    ):
        self.bus, self.joints, self.limits, self.options = bus, robot.joints, limits, options
        self.records = tuple(ServoHealth(j.name, j.servo_id) for j in robot.joints)
        n = len(robot.joints)
        readable = bus.capabilities.supports
        self._rotation = [
            item
            for c in range(n)
            for item in [(i, Reading.POSITION) for i in range(n)]
            + [(c, Reading.VIN), (c, Reading.TEMPERATURE)]
            if readable(item[1].value[0])
        ]
        self._next = 0
        self._suspect: int | None = None  # a joint whose last read went unanswered: read it next
        self.cost_s = options.health_timeout_s + options.start_guard_s  # bus time a read needs

    def read(self, budget_s: float, expected_units) -> bool:
        """One health read if it fits in ``budget_s``; whether it was made. ``expected_units``:
        where each servo should be now (joint order)."""
        if budget_s < self.cost_s:
            return False
        index, reading = self._pick()
        joint, health = self.joints[index], self.records[index]
        command, field = reading.value
        try:
            value = self.bus.request(
                command, joint.servo_id, retries=0, timeout_s=self.options.health_timeout_s
            )[field]
        except (BusTimeoutError, ProtocolError) as error:  # one bad read is noise; a run is not
            self._missed(index, error)
            return True
        health.missed_reads = 0
        health.reads += 1
        self._suspect = None
        self._check(joint, health, reading, value, expected_units[index])
        return True

    def _pick(self) -> tuple[int, Reading]:
        if self._suspect is not None:
            return self._suspect, Reading.POSITION
        item = self._rotation[self._next % len(self._rotation)]
        self._next += 1
        return item

    def _missed(self, index: int, error: Exception) -> None:
        joint, health = self.joints[index], self.records[index]
        health.missed_reads += 1
        health.missed_total += 1
        self._suspect = index
        log.info("health read of %s missed: %s", joint.name, error)
        if health.missed_reads >= self.options.max_missed_reads:
            raise PlaybackAborted.naming(
                "health_timeout_s",
                f"{names([joint])} stopped answering ({health.missed_reads} reads in a row timed "
                "out or came back garbled); check its cable, or allow a slow USB adapter more "
                "time ({option})",
            ) from None

    def _check(
        self, joint: Joint, health: ServoHealth, reading: Reading, value: int, expected: float
    ) -> None:
        limits, who = self.limits[joint.name], names([joint])
        if reading is Reading.TEMPERATURE:
            health.saw_temperature(value)
            if limits.max_temp_c is not None and (
                value >= limits.max_temp_c - self.options.temp_margin_c
            ):
                raise ServoFault(
                    f"{who} is at {value} °C, near its limit {limits.max_temp_c} °C",
                    servo_id=joint.servo_id,
                    command=Command.TEMP_READ,
                )
        elif reading is Reading.VIN:
            health.saw_vin(value)
            low, high = limits.min_vin_mv, limits.max_vin_mv
            if low is not None and high is not None and not low <= value <= high:
                raise ServoFault(
                    f"{who} supply is {value} mV, outside {low}..{high} mV",
                    servo_id=joint.servo_id,
                    command=Command.VIN_READ,
                )
        else:
            error_deg = abs(joint.to_deg(value) - joint.to_deg(expected))
            health.saw_position_error(error_deg)
            if error_deg > self.options.max_position_error_deg:
                raise PlaybackAborted(
                    f"{who} is {error_deg:.1f}° away from where it should be "
                    f"(limit {self.options.max_position_error_deg:g}°): blocked or overloaded?"
                )
