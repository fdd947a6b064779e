"""Motion files: ``motions/<robot>/*.yaml`` -> a validated, flattened ``Motion``.

Includes are expanded and mirrored here; every keyframe carries a full target vector (degrees,
in the robot's joint order) and where it was written, so later stages can point at the line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .robot import Robot, SourceLocation


@dataclass(frozen=True)
class Keyframe:
    targets_deg: tuple[float, ...]  # every joint, robot joint order (partial poses filled in)
    where: SourceLocation  # the keyframe's line in its file (the included file for includes)
    t_s: float | None = None  # absolute time from the motion start, before speed scaling
    after_s: float | None = None  # seconds after the previous keyframe (at most one of t/after)
    hold_s: float = 0.0  # stay this long once reached
    stop: bool = False  # come to rest here (implied by hold > 0, and at the ends)
    velocity_scale: float = 1.0  # 0 < scale <= 1: fraction of the joint velocity limits
    label: str = ""  # pose name, or "" for an inline pose


@dataclass(frozen=True)
class Motion:
    name: str
    path: Path
    robot: Robot
    keyframes: tuple[Keyframe, ...]
    description: str = ""
    speed: float = 1.0  # time scale: 2.0 plays twice as fast
    repeat: int = 1  # times to play; the planner wraps seamlessly from the last keyframe to the first
