"""The robot as the rest of choreo sees it: joints (servo, zero, direction, limits), named poses,
mirror pairs and bus settings, with the conversions between joint degrees and servo units.

A joint angle maps to a servo position by ``units = zero_units + direction * angle_deg * 1000/240``.
Reading a robot.yaml into a ``Robot`` is ``choreo.robot.robot_file.load_robot``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from choreo.bus.servo_models import DEG_PER_UNIT, UNITS_PER_DEG, rated_supply_problem
from choreo.bus.settings import BusSettings
from choreo.core.yaml_source import fmt

if TYPE_CHECKING:  # (it reads a file against a Robot)
    from choreo.robot.servo_figures import ServoFigures

# A float, or a numpy array of them: the conversions and the limit check take either.
Values = TypeVar("Values", float, np.ndarray)


def deg_to_units(angle_deg: Values, zero_units: Values, direction: Values) -> Values:
    """Servo position (not rounded) for a joint angle: the one formula, element-wise on arrays."""
    return zero_units + direction * angle_deg * UNITS_PER_DEG


def units_to_deg(position_units: Values, zero_units: Values, direction: Values) -> Values:
    """Joint angle for a servo position (the inverse of ``deg_to_units``)."""
    return (position_units - zero_units) * direction * DEG_PER_UNIT


def within(angle_deg: Values, min_deg: Values, max_deg: Values) -> Values:
    """The one joint-limit test, ends included (element-wise on arrays; NaN is never within)."""
    return (min_deg <= angle_deg) & (angle_deg <= max_deg)


@dataclass(frozen=True)
class JointLimits:
    min_deg: float
    max_deg: float
    vel_deg_s: float
    acc_deg_s2: float
    jerk_deg_s3: float

    def contains(self, angle_deg: float) -> bool:
        return bool(within(angle_deg, self.min_deg, self.max_deg))

    @property
    def range_text(self) -> str:
        """The position range for messages: ``-90..90°``."""
        return f"{fmt(self.min_deg)}..{fmt(self.max_deg)}°"


@dataclass(frozen=True)
class Joint:
    name: str
    servo_id: int
    servo_model: str  # a key of choreo.bus.servo_models.SERVO_MODELS
    zero_units: float  # servo position at joint angle 0
    direction: int  # +1 or -1
    limits: JointLimits
    mjcf_joint: str  # the MuJoCo joint this servo drives
    # preview actuator values overriding the servo model's (keys: servos.ACTUATOR_FIELDS)
    actuator: Mapping[str, float] = field(default_factory=dict, hash=False)  # (a dict can't hash)

    def __post_init__(self) -> None:
        object.__setattr__(self, "actuator", MappingProxyType(dict(self.actuator)))

    def to_units(self, angle_deg: float) -> float:
        """Servo position (not rounded) for a joint angle."""
        return deg_to_units(angle_deg, self.zero_units, self.direction)

    def to_deg(self, position_units: float) -> float:
        """Joint angle for a servo position."""
        return units_to_deg(position_units, self.zero_units, self.direction)

    @property
    def limits_units(self) -> tuple[float, float]:
        """The joint limits as servo positions (not rounded), the lower first."""
        ends = self.to_units(self.limits.min_deg), self.to_units(self.limits.max_deg)
        return min(ends), max(ends)


@dataclass(frozen=True)
class LimitViolation:
    """A joint angle outside the joint's limits."""

    joint: Joint
    angle_deg: float

    def __str__(self) -> str:
        return (
            f"{self.joint.name} at {fmt(self.angle_deg)}° is outside its limits "
            f"{self.joint.limits.range_text}"
        )


@dataclass(frozen=True)
class MirrorPair:
    left: str
    right: str
    sign: int  # right = sign * left (and left = sign * right)


@dataclass(frozen=True)
class GaitCompensation:
    """What a legged robot's gaits command beyond what they ask, to make up for how far the
    robot falls short of its plan (the servos sag under its weight, the feet slip): the robot
    file's ``gait:`` block; the defaults change nothing."""

    lift_sag_mm: float = 0.0  # added to every lift above 0
    stride_scale: float = 1.0  # forward and sideways
    turn_scale: float = 1.0


@dataclass(frozen=True)
class Robot:
    name: str
    path: Path  # robot.yaml
    joints: tuple[Joint, ...]
    poses: Mapping[str, Mapping[str, float]]  # pose name -> joint name -> degrees (all joints)
    mirror_pairs: tuple[MirrorPair, ...] = ()
    bus: BusSettings = field(default_factory=BusSettings)
    mjcf_path: Path | None = None  # models/<name>/<name>.xml
    scene_path: Path | None = None  # models/<name>/scene.xml
    free_floating: bool = False  # the MJCF root body has a free joint
    gait: GaitCompensation = field(default_factory=GaitCompensation)
    # the measured servo figures the robot file names (``servo_figures:``), already applied to
    # the joints' actuator figures and velocity limits; None: every figure is assumed
    servo_figures: ServoFigures | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", MappingProxyType(dict(self.poses)))

    def declared_supply_v(self, joint: Joint) -> float | None:
        """The supply the robot file declares for ``joint`` (its ``actuator: supply_v``, else
        ``bus: supply_v``); None: not declared (each servo model's rated supply is assumed)."""
        return joint.actuator.get("supply_v", self.bus.supply_v)

    def supply_problems(self) -> list[str]:
        """The declared supply against each joint's servo model's rated range: one line per
        supply and model, naming its joints (``choreo play`` refuses a servo reading such a
        supply, and the preview's servos are weaker or stronger than rated)."""
        joints_by_problem: dict[str, list[str]] = {}
        for joint in self.joints:
            supply = self.declared_supply_v(joint)
            problem = None if supply is None else rated_supply_problem(joint.servo_model, supply)
            if problem is not None:
                joints_by_problem.setdefault(problem, []).append(joint.name)
        return [
            f"{', '.join(joints)}: {problem} (the robot file's supply_v): `choreo play` refuses "
            "such a supply; use a supply inside it, or name the servo model the robot has"
            for problem, joints in joints_by_problem.items()
        ]

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @cached_property
    def joints_by_name(self) -> Mapping[str, Joint]:
        """The joints by name (read-only), looked up for every pose of a motion."""
        return MappingProxyType({j.name: j for j in self.joints})

    def joint(self, name: str) -> Joint:
        return self.joints_by_name[name]

    def pose_vector(self, pose: str) -> tuple[float, ...]:
        """A named pose as degrees in joint order."""
        values = self.poses[pose]
        return tuple(values[j.name] for j in self.joints)

    # --- every joint at once: arrays whose last axis is the robot's joint order ---

    def to_units(self, angles_deg: np.ndarray | Sequence[float]) -> np.ndarray:
        """Servo positions (not rounded) for joint angles."""
        return deg_to_units(np.asarray(angles_deg, dtype=float), *self._servo_map)

    def to_deg(self, positions_units: np.ndarray | Sequence[float]) -> np.ndarray:
        """Joint angles for servo positions."""
        return units_to_deg(np.asarray(positions_units, dtype=float), *self._servo_map)

    def outside_limits(self, angles_deg: np.ndarray | Sequence[float]) -> np.ndarray:
        """True where an angle is outside its joint's limits (or not a number)."""
        return ~within(np.asarray(angles_deg, dtype=float), *self._limits_deg)

    def limit_violations(
        self, angles_deg: Mapping[str, float] | Sequence[float]
    ) -> list[LimitViolation]:
        """The angles of one pose outside their joints' limits, in the order given: a mapping
        names some joints, a sequence gives every joint in robot joint order."""
        if isinstance(angles_deg, Mapping):
            index = [self.joint_names.index(name) for name in angles_deg]
            values = list(angles_deg.values())
        else:
            index, values = list(range(len(self.joints))), list(angles_deg)
            if len(values) != len(index):
                raise ValueError(f"{len(values)} angles for the {len(index)} joints of {self.name}")
        low, high = self._limits_deg
        inside = within(np.asarray(values, dtype=float), low[index], high[index])
        return [
            LimitViolation(self.joints[j], value)
            for j, value, ok in zip(index, values, inside)
            if not ok
        ]

    @cached_property
    def _servo_map(self) -> tuple[np.ndarray, np.ndarray]:
        """(zero_units, direction) per joint."""
        return (
            np.array([j.zero_units for j in self.joints], dtype=float),
            np.array([j.direction for j in self.joints], dtype=float),
        )

    @cached_property
    def _limits_deg(self) -> tuple[np.ndarray, np.ndarray]:
        """(min_deg, max_deg) per joint."""
        return (
            np.array([j.limits.min_deg for j in self.joints], dtype=float),
            np.array([j.limits.max_deg for j in self.joints], dtype=float),
        )


# --- mirroring ---------------------------------------------------------------------------------


def mirror_pose(robot: Robot, angles_deg: Mapping[str, float]) -> dict[str, float]:
    """A (possibly partial) pose mirrored with the robot's mirror pairs.

    For a pair, the right joint gets ``sign * left`` and the left joint ``sign * right``; a joint
    paired with itself gets ``sign * value``; joints in no pair keep their value. Only joints
    whose source was given appear in the result. Limits are not checked here.
    """
    paired = {name for pair in robot.mirror_pairs for name in (pair.left, pair.right)}
    mirrored = {name: value for name, value in angles_deg.items() if name not in paired}
    for pair in robot.mirror_pairs:
        if pair.left in angles_deg:
            mirrored[pair.right] = pair.sign * angles_deg[pair.left]
        if pair.right in angles_deg:
            mirrored[pair.left] = pair.sign * angles_deg[pair.right]
    return mirrored


def mirror_targets(robot: Robot, targets_deg: tuple[float, ...]) -> tuple[float, ...]:
    """A full target vector (robot joint order) mirrored left<->right; see ``mirror_pose``."""
    if len(targets_deg) != len(robot.joints):
        raise ValueError(
            f"targets_deg has {len(targets_deg)} values; robot {robot.name!r} has "
            f"{len(robot.joints)} joints"
        )
    mirrored = mirror_pose(robot, dict(zip(robot.joint_names, targets_deg)))
    return tuple(mirrored[name] for name in robot.joint_names)
