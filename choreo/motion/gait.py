"""Where a walker's feet go, in its body frame, keyframe by keyframe: body poses and gaits.

Pure geometry (no MuJoCo): the feet are points, the floor is the plane they stand on, and the
result is foot positions (mm, body frame) that ``choreo.motion.spatial`` turns into joint angles
by IK.

A gait of ``steps`` steps moves the body by ``stride`` mm forward, ``sideways`` mm to the left
and turns it ``turn_deg`` counter-clockwise (seen from above) per step; in one step every leg
swings once, the legs of one group of the pattern at a time. The body moves steadily; each
swing lands its foot where that foot stands at home under the body's pose halfway through the
stance that follows (so every foot works as far ahead of its neutral spot as behind it), the
last ones under the gait's end pose, so after the last step the robot stands as it started,
``steps`` strides further on.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

# Feet in the order the MJCF lists them: left front, middle, rear, then right front, middle, rear.
SIX_LEGS = 6
# Keyframes of one group's swing, as fractions of it: the foot rises, crosses and sets down on a
# half sine, so the joint-space moves between keyframes stay close to that path.
SWING_SAMPLES = (0.25, 0.5, 0.75, 1.0)


class Pattern(Enum):
    TRIPOD = "tripod"  # two groups of three: lf rm lr, then rf lm rr
    RIPPLE = "ripple"  # three groups of two, one leg per side: lr rf, lm rr, lf rm
    WAVE = "wave"  # one leg at a time, rear to front: rr rm rf lr lm lf


GROUPS: dict[Pattern, tuple[tuple[int, ...], ...]] = {
    Pattern.TRIPOD: ((0, 4, 2), (3, 1, 5)),
    Pattern.RIPPLE: ((2, 3), (1, 5), (0, 4)),
    Pattern.WAVE: ((5,), (4,), (3,), (2,), (1,), (0,)),
}


@dataclass(frozen=True)
class Gait:
    pattern: Pattern
    steps: int
    stride_mm: float = 40.0
    sideways_mm: float = 0.0
    turn_deg: float = 0.0
    lift_mm: float = 30.0
    period_s: float = 2.0  # one step: every leg swings once

    @property
    def keyframes_per_step(self) -> int:
        return len(SWING_SAMPLES) * len(GROUPS[self.pattern])

    @property
    def keyframe_s(self) -> float:
        """The time between the gait's keyframes."""
        return self.period_s / self.keyframes_per_step


@dataclass(frozen=True)
class BodyPose:
    """The body moved from where it stood, feet planted: mm and degrees, body frame axes."""

    x_mm: float = 0.0
    y_mm: float = 0.0
    z_mm: float = 0.0
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0

    def rotation(self) -> np.ndarray:
        roll, pitch, yaw = np.radians([self.roll_deg, self.pitch_deg, self.yaw_deg])
        return _rot_z(yaw) @ _rot_y(pitch) @ _rot_x(roll)


@dataclass(frozen=True)
class GaitKeyframe:
    feet_mm: np.ndarray  # (feet, 3) body frame
    step: int  # 1-based step of the gait
    body_mm_deg: tuple[float, float, float]  # body x, y (mm) and heading (deg) on the floor


def feet_under_body(stance_mm: np.ndarray, pose: BodyPose) -> np.ndarray:
    """Feet planted at ``stance_mm`` (body frame before) seen from the body moved by ``pose``."""
    offset = np.array([pose.x_mm, pose.y_mm, pose.z_mm])
    return (np.asarray(stance_mm) - offset) @ pose.rotation()  # R^T (p - t), row by row


def gait_keyframes(stance_mm: np.ndarray, gait: Gait) -> list[GaitKeyframe]:
    """Foot positions (body frame) at every keyframe of the gait, one per swing sample."""
    stance_mm = np.asarray(stance_mm, dtype=float)
    groups = GROUPS[gait.pattern]
    per_phase = np.array([gait.stride_mm, gait.sideways_mm, np.radians(gait.turn_deg)]) / len(
        groups
    )
    body = np.zeros(3)  # x mm, y mm, heading rad on the floor
    footholds = stance_mm.copy()  # floor frame (the body's start)
    keyframes = []
    last_phase = gait.steps * len(groups)
    for step in range(1, gait.steps + 1):
        for index, group in enumerate(groups):
            landing = _to_floor(
                _body_after(per_phase, _mid_stance_phase(step, index, len(groups), last_phase)),
                stance_mm,
            )
            for fraction in SWING_SAMPLES:
                now = _compose(body, per_phase * fraction)
                feet = footholds.copy()
                for leg in group:
                    along = (1 - np.cos(np.pi * fraction)) / 2  # slow off and onto the floor
                    feet[leg] = footholds[leg] + along * (landing[leg] - footholds[leg])
                    feet[leg, 2] += gait.lift_mm * np.sin(np.pi * fraction)
                keyframes.append(GaitKeyframe(_to_body(now, feet), step, _floor_pose(now)))
            for leg in group:
                footholds[leg] = landing[leg]
            body = _compose(body, per_phase)
    return keyframes


def _mid_stance_phase(step: int, group: int, groups: int, last_phase: int) -> float:
    """Where (in group phases from the gait's start) the body is halfway through the stance
    that follows this swing: the swing lands ``group``'s feet under that pose, so each foot
    works as far ahead of its neutral spot as behind it, whichever group it is in. The last
    stance ends with the gait, where every foot must stand at its neutral spot."""
    landed = (step - 1) * groups + group + 1  # the phase its swing ends
    lifts_again = landed + groups - 1  # its next swing starts then
    return last_phase if lifts_again >= last_phase else (landed + lifts_again) / 2


def _body_after(per_phase: np.ndarray, phases: float) -> np.ndarray:
    """The body's floor pose after ``phases`` (fractional) group phases from the start."""
    body = np.zeros(3)
    for _ in range(int(phases)):
        body = _compose(body, per_phase)
    return _compose(body, per_phase * (phases - int(phases)))


def _compose(pose: np.ndarray, move: np.ndarray) -> np.ndarray:
    """``pose`` followed by ``move`` given in the body's own frame (x, y, heading)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array(
        [
            pose[0] + c * move[0] - s * move[1],
            pose[1] + s * move[0] + c * move[1],
            pose[2] + move[2],
        ]
    )


def _to_floor(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    out = points @ _rot_z(pose[2]).T
    out[:, :2] += pose[:2]
    return out


def _to_body(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    shifted = points.copy()
    shifted[:, :2] -= pose[:2]
    return shifted @ _rot_z(pose[2])


def _floor_pose(pose: np.ndarray) -> tuple[float, float, float]:
    return float(pose[0]), float(pose[1]), float(np.degrees(pose[2]))


def _rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
