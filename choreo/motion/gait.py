"""Where a walker's feet go, in its body frame, keyframe by keyframe: body poses and gaits.

Pure geometry (no MuJoCo): the feet are points, the floor is the plane they stand on, and the
result is foot positions (mm, body frame) that ``choreo.motion.spatial`` turns into joint angles
by IK.

A gait of ``steps`` steps moves the body by ``stride`` mm forward, ``sideways`` mm to the left
and turns it ``turn_deg`` counter-clockwise (seen from above) per step; in one step (the period)
every leg swings once, each at its own phase of the period (``PHASES``): tripod and wave swing
their legs in turn, ripple runs a wave on each side with the two sides half a period apart, so
its swings overlap. The body moves steadily; each swing lands its foot where that foot stands at
home under the body's pose halfway through the stance that follows (so every foot works as far
ahead of its neutral spot as behind it), the last ones under the gait's end pose, so after the
last step the robot stands as it started, ``steps`` strides further on.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

# Feet in the order the MJCF lists them: left front, middle, rear, then right front, middle, rear.
SIX_LEGS = 6
# Keyframes of one swing, as fractions of it: the foot rises, crosses and sets down on a half
# sine, so the joint-space moves between keyframes stay close to that path.
SWING_SAMPLES = (0.25, 0.5, 0.75, 1.0)


class Pattern(Enum):
    TRIPOD = "tripod"  # two groups of three: lf rm lr, then rf lm rr
    RIPPLE = "ripple"  # a wave on each side (rear to front), the sides half a period apart
    WAVE = "wave"  # one leg at a time, rear to front: rr rm rf lr lm lf


@dataclass(frozen=True)
class Phases:
    """When each leg swings within a step, on the gait's keyframe grid: a step is ``slots``
    keyframes, every swing ``len(SWING_SAMPLES)`` of them, and leg ``i`` lifts off
    ``lift_off[i]`` keyframes into the step (a swing may run on into the next step)."""

    slots: int
    lift_off: tuple[int, ...]  # lf lm lr rf rm rr

    @property
    def duty_factor(self) -> float:
        """The share of the period each foot is on the floor."""
        return 1 - len(SWING_SAMPLES) / self.slots

    @property
    def offsets(self) -> tuple[float, ...]:
        """Each leg's lift-off as a fraction of the period."""
        return tuple(slot / self.slots for slot in self.lift_off)

    @property
    def overhang(self) -> int:
        """Keyframes the last swings run past the last step's end."""
        return max(0, max(self.lift_off) + len(SWING_SAMPLES) - self.slots)


PHASES: dict[Pattern, Phases] = {
    # duty factor 1/2: tripod A (lf, rm, lr) swings while B stands, then B: three feet always down
    Pattern.TRIPOD: Phases(8, (0, 4, 0, 4, 0, 4)),
    # duty factor 2/3: on each side a wave rear to front, its legs 1/3 period apart (lr 0, lm 1/3,
    # lf 2/3), the right side half a period behind (rr 1/2, rm 5/6, rf 1/6): one leg per side in
    # the air, never two neighbours, so four feet are always down and the swings overlap by half
    Pattern.RIPPLE: Phases(12, (8, 4, 0, 2, 10, 6)),
    # duty factor 5/6: one leg at a time, rr rm rf lr lm lf, 1/6 period apart: five feet down
    Pattern.WAVE: Phases(24, (20, 16, 12, 8, 4, 0)),
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
        return PHASES[self.pattern].slots

    @property
    def keyframes(self) -> int:
        """All the gait's keyframes: its steps, then the swings that run past the last one."""
        return self.steps * self.keyframes_per_step + PHASES[self.pattern].overhang

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
    """Foot positions (body frame) at every keyframe of the gait."""
    stance_mm = np.asarray(stance_mm, dtype=float)
    phases = PHASES[gait.pattern]
    swing = len(SWING_SAMPLES)
    moving = gait.steps * phases.slots  # the body moves until the last step ends, then stands
    per_slot = np.array([gait.stride_mm, gait.sideways_mm, np.radians(gait.turn_deg)])
    bodies = [np.zeros(3)]  # x mm, y mm, heading rad on the floor, at every keyframe
    for _ in range(moving):
        bodies.append(_compose(bodies[-1], per_slot / phases.slots))
    bodies += [bodies[-1]] * phases.overhang
    # every keyframe's swinging legs: (leg, fraction of its swing, from, to on the floor)
    swinging: dict[int, list[tuple[int, float, np.ndarray, np.ndarray]]] = {}
    for leg, first in enumerate(phases.lift_off):
        origin = stance_mm[leg]  # floor frame (the body's start)
        for step in range(gait.steps):
            lift_off = step * phases.slots + first
            mid_stance = lift_off + swing + (phases.slots - swing) // 2
            landing = _to_floor(bodies[moving if step == gait.steps - 1 else mid_stance], stance_mm)
            for slot, fraction in enumerate(SWING_SAMPLES, start=lift_off + 1):
                swinging.setdefault(slot, []).append((leg, fraction, origin, landing[leg]))
            origin = landing[leg]
    footholds = stance_mm.copy()
    keyframes = []
    for slot in range(1, gait.keyframes + 1):
        feet = footholds.copy()
        for leg, fraction, origin, landing in swinging.get(slot, []):
            along = (1 - np.cos(np.pi * fraction)) / 2  # slow off and onto the floor
            feet[leg] = origin + along * (landing - origin)
            feet[leg, 2] += gait.lift_mm * np.sin(np.pi * fraction)
            if fraction == SWING_SAMPLES[-1]:
                footholds[leg] = landing
        body = bodies[slot]
        step = min(gait.steps, (slot - 1) // phases.slots + 1)
        keyframes.append(GaitKeyframe(_to_body(body, feet), step, _floor_pose(body)))
    return keyframes


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
