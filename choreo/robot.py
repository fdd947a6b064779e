"""Robot descriptions: ``models/<name>/robot.yaml`` -> a validated ``Robot``.

Angles are degrees everywhere above the bus. A joint angle maps to a servo position by
``units = zero_units + direction * angle_deg * 1000/240``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from .servos import DEG_PER_UNIT, UNITS_PER_DEG


@dataclass(frozen=True)
class SourceLocation:
    """Where a value came from, for messages: ``path:line:col``."""

    path: Path
    line: int  # 1-based
    col: int  # 1-based

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.col}"


@dataclass(frozen=True)
class JointLimits:
    min_deg: float
    max_deg: float
    vel_deg_s: float
    acc_deg_s2: float
    jerk_deg_s3: float


@dataclass(frozen=True)
class Joint:
    name: str
    servo_id: int
    servo_model: str  # a key of choreo.servos.SERVO_MODELS
    zero_units: float  # servo position at joint angle 0
    direction: int  # +1 or -1
    limits: JointLimits
    mjcf_joint: str  # the MuJoCo joint this servo drives

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
    baudrate: int = 115200
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
