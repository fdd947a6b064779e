"""The robot as the rest of choreo sees it: joints (servo, zero, direction, limits), named poses,
mirror pairs and bus settings, with the conversions between joint degrees and servo units.

A joint angle maps to a servo position by ``units = zero_units + direction * angle_deg * 1000/240``.
Reading a robot.yaml into a ``Robot`` is ``choreo.robot_file.load_robot``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from .servos import DEG_PER_UNIT, UNITS_PER_DEG
from .yamlsource import fmt


@dataclass(frozen=True)
class JointLimits:
    min_deg: float
    max_deg: float
    vel_deg_s: float
    acc_deg_s2: float
    jerk_deg_s3: float

    def contains(self, angle_deg: float) -> bool:
        return self.min_deg <= angle_deg <= self.max_deg

    @property
    def range_text(self) -> str:
        """The position range for messages: ``-90..90°``."""
        return f"{fmt(self.min_deg)}..{fmt(self.max_deg)}°"


@dataclass(frozen=True)
class Joint:
    name: str
    servo_id: int
    servo_model: str  # a key of choreo.servos.SERVO_MODELS
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
        return self.zero_units + self.direction * angle_deg * UNITS_PER_DEG

    def to_deg(self, position_units: float) -> float:
        """Joint angle for a servo position."""
        return (position_units - self.zero_units) * self.direction * DEG_PER_UNIT


@dataclass(frozen=True)
class MirrorPair:
    left: str
    right: str
    sign: int  # right = sign * left (and left = sign * right)


@dataclass(frozen=True)
class BusSettings:
    port: str | None = None  # None: the built-in emulated bus
    timeout_s: float = 0.05
    retries: int = 2
    echo: str = "auto"  # none | discard | auto


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

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", MappingProxyType(dict(self.poses)))

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def pose_vector(self, pose: str) -> tuple[float, ...]:
        """A named pose as degrees in joint order."""
        values = self.poses[pose]
        return tuple(values[j.name] for j in self.joints)


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
