"""Preflight: before anything moves, every servo of the robot must answer and be fit to move.

Refused, with every problem in one error: servos that do not answer or answer garbled (two on one
ID), a servo in motor mode (MOVE_STOP could not stop it), a supply outside the servo's limits or
its model's rating, a servo at its temperature limit, and angle limits stored in the servo that
are narrower than the robot file's. Then torque is loaded. Checks the transport cannot make
(``capabilities``) are skipped and listed by :func:`unchecked`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import Presence, ServoBus
from choreo.bus.servo_models import rated_supply_problem
from choreo.bus.typed_commands import AngleLimits, MotorMode, VinLimits
from choreo.core.arguments import check_type
from choreo.errors import ChoreoError
from choreo.robot.types import Joint, Robot

T = TypeVar("T")

PREFLIGHT_READS = {
    Command.VIN_READ: "supply voltage",
    Command.VIN_LIMIT_READ: "voltage limits",
    Command.TEMP_READ: "temperature",
    Command.TEMP_MAX_LIMIT_READ: "temperature limit",
    Command.ANGLE_LIMIT_READ: "angle limits",
    Command.OR_MOTOR_MODE_READ: "motor mode",
}


@dataclass(frozen=True)
class ServoLimits:
    """What preflight read from a servo: the bounds the health checks enforce."""

    min_vin_mv: int | None  # None: the transport cannot read it
    max_vin_mv: int | None
    max_temp_c: int | None


@dataclass(frozen=True)
class _Fitness:
    """What preflight read from one servo (None: the transport cannot read it)."""

    position_units: int
    vin_mv: int | None
    vin_limits: VinLimits | None
    temp_c: int | None
    temp_limit_c: int | None
    angle_limits: AngleLimits | None
    mode: MotorMode | None

    @property
    def limits(self) -> ServoLimits:
        vin = self.vin_limits
        if vin is None:
            return ServoLimits(None, None, self.temp_limit_c)
        return ServoLimits(vin.min_mv, vin.max_mv, self.temp_limit_c)


def preflight(bus: ServoBus, robot: Robot) -> tuple[tuple[float, ...], dict[str, ServoLimits]]:
    """Check that every servo answers and is fit to move; load torque.

    Returns the measured pose (degrees, joint order) and each joint's servo limits. Raises a
    ChoreoError listing every problem; nothing has moved then.
    """
    check_bus_and_robot(bus, robot)
    _check_presence(bus, robot)
    pose, limits = [], {}
    found: dict[str, list[Joint]] = {}  # a problem -> the joints that have it, in order
    for joint in robot.joints:
        fitness = _read_fitness(bus, joint.servo_id)
        pose.append(joint.to_deg(fitness.position_units))
        limits[joint.name] = fitness.limits
        for problem in _problems(joint, fitness):
            found.setdefault(problem, []).append(joint)
    if found:
        lines = [f"{names(joints)}: {problem}" for problem, joints in found.items()]
        raise ChoreoError("refusing to play:\n  " + "\n  ".join(lines))
    if bus.capabilities.load:  # else the approach's first move powers the servos
        for joint in robot.joints:
            bus.load(joint.servo_id)
    return tuple(pose), limits


def check_bus_and_robot(bus: object, robot: object) -> None:
    check_type("bus", bus, ServoBus, "an open ServoBus: ServoBus(port)")
    check_type("robot", robot, Robot, "a Robot (load_robot, or a motion's .robot)")


def unchecked(bus: ServoBus) -> list[str]:
    """What preflight and the health reads cannot check through this transport."""
    return [
        what for command, what in PREFLIGHT_READS.items() if not bus.capabilities.supports(command)
    ]


def names(joints: Sequence[Joint]) -> str:
    """``"elbow (ID 3), wrist (ID 4)"``: joints as messages name them."""
    return ", ".join(f"{j.name} (ID {j.servo_id})" for j in joints)


def _check_presence(bus: ServoBus, robot: Robot) -> None:
    presence = {j: bus.presence(j.servo_id, retries=2) for j in robot.joints}
    silent = [j for j, p in presence.items() if p is Presence.SILENT]
    garbled = [j for j, p in presence.items() if p is Presence.GARBLED]
    problems = []
    if silent:
        problems.append(f"{len(silent)} servo(s) did not answer: {names(silent)}")
    if garbled:
        problems.append(
            f"{len(garbled)} servo(s) answered garbled, as when two servos share an "
            f"ID: {names(garbled)}"
        )
    if problems:
        raise ChoreoError(
            "; ".join(problems) + "; check power and wiring, or run `choreo scan` "
            "to see which IDs answer"
        )


def _read_fitness(bus: ServoBus, sid: int) -> _Fitness:
    def read(command: Command, reader: Callable[[int], T]) -> T | None:
        return reader(sid) if bus.capabilities.supports(command) else None

    return _Fitness(
        position_units=bus.read_position(sid),
        vin_mv=read(Command.VIN_READ, bus.read_vin),
        vin_limits=read(Command.VIN_LIMIT_READ, bus.read_vin_limits),
        temp_c=read(Command.TEMP_READ, bus.read_temperature),
        temp_limit_c=read(Command.TEMP_MAX_LIMIT_READ, bus.read_temp_limit),
        angle_limits=read(Command.ANGLE_LIMIT_READ, bus.read_angle_limits),
        mode=read(Command.OR_MOTOR_MODE_READ, bus.read_mode),
    )


def _problems(joint: Joint, fit: _Fitness) -> list[str]:
    """Why ``joint``'s servo must not play, each without its name (joints share a line)."""
    problems = []
    if fit.mode is not None and fit.mode.motor:
        problems.append(
            f"is in motor mode (turning at duty {fit.mode.speed}), which MOVE_STOP "
            "cannot stop; stop its motor first (choreo.bus.servo_config.stop_motor)"
        )
    vin, vin_limits = fit.vin_mv, fit.vin_limits
    if (
        vin is not None
        and vin_limits is not None
        and not vin_limits.min_mv <= vin <= vin_limits.max_mv
    ):
        problems.append(
            f"supply {vin} mV is outside the servo's limits "
            f"{vin_limits.min_mv}..{vin_limits.max_mv} mV; check the power supply"
        )
    if vin is not None:
        problems += _model_supply_problems(joint, vin)
    if fit.temp_c is not None and fit.temp_limit_c is not None and fit.temp_c >= fit.temp_limit_c:
        problems.append(
            f"{fit.temp_c} °C is at or above the servo's limit {fit.temp_limit_c} °C; let it "
            "cool down"
        )
    low, high = joint.limits_units
    stored = fit.angle_limits
    if stored is not None and (stored.min_units > round(low) or stored.max_units < round(high)):
        problems.append(
            f"the servo's own angle limits {stored.min_units}..{stored.max_units}"
            f" are narrower than the robot file's {round(low)}..{round(high)} units "
            f"({joint.limits.min_deg:g}..{joint.limits.max_deg:g}°); widen them with "
            "`choreo servo limits` or narrow the joint limits in the robot file"
        )
    return problems


def _model_supply_problems(joint: Joint, vin_mv: int) -> list[str]:
    """The supply against the rated range of the model the robot file names (the limits stored
    in the servo are often the protocol's 4.5-14 V, which lets an LX-16A run on 11 V)."""
    problem = rated_supply_problem(joint.servo_model, round(vin_mv / 1000, 1))
    if problem is None:
        return []
    return [
        f"{problem} (the robot file's servo model); check the power supply, or the joint's "
        "servo model in the robot file"
    ]
