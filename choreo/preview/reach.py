"""Targets reached: where each ``sites:`` keyframe's site really is in the simulation when the
keyframe is due, against where the motion asked for it (IK solves the joints exactly; the arm
then sags under its own weight and the servos' dead band, and lags when it moves fast).

Both are in the robot's base frame (its MJCF's first body, as ``sites:`` positions are), so a
walker's targets are judged relative to its body wherever it has walked.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.core.yaml_source import SourceLocation
from choreo.motion.spatial import SiteTarget

# a site farther than this from its target: a warning (half a 30 mm block: a grasp aimed at its
# middle is off to one side) ...
REACH_WARNING_MM = 15.0
_SAMPLE_STEPS = 10  # physics steps between samples over a hold
REACH_ERROR_MM = 30.0  # ... farther than this: an error (the block would be missed altogether)


@dataclass(frozen=True)
class SiteReach:
    keyframe: int  # index among the played keyframes
    time_s: float  # when it was farthest, from its keyframe's arrival to the end of its hold
    site: str
    target_mm: tuple[float, float, float]  # base frame
    reached_mm: tuple[float, float, float]  # base frame, in the simulation
    where: SourceLocation  # the target's line

    @property
    def error_mm(self) -> float:
        return float(np.linalg.norm(np.subtract(self.reached_mm, self.target_mm)))

    def to_dict(self) -> dict:
        return {
            "keyframe": self.keyframe,
            "time_s": round(self.time_s, 4),
            "site": self.site,
            "target_mm": [round(v, 1) for v in self.target_mm],
            "reached_mm": [round(v, 1) for v in self.reached_mm],
            "error_mm": round(self.error_mm, 1),
            "line": str(self.where),
        }


@dataclass(frozen=True)
class SitesDue:
    """A played ``sites:`` keyframe: when it is due (from the motion start) and held."""

    keyframe: int
    arrival_s: float
    hold_s: float
    sites: tuple[SiteTarget, ...]


def site_reach(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    times_s: np.ndarray,
    due: Sequence[SitesDue],
    base_body: str,
    world_to_base_mm,
) -> tuple[SiteReach, ...]:
    """Every ``sites:`` target, measured from when its keyframe is due to the end of its hold
    (the worst moment: an arm may reach and then sink). ``base_body`` is the robot's base frame
    and ``world_to_base_mm`` turns a ``frame: world`` target into it, as IK did."""
    data = mujoco.MjData(model)
    base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, base_body)
    last = len(times_s) - 1
    out = []
    for keyframe in due:
        first = min(int(np.searchsorted(times_s, keyframe.arrival_s - 1e-9)), last)
        end = min(int(np.searchsorted(times_s, keyframe.arrival_s + keyframe.hold_s)), last)
        steps = np.unique(np.r_[np.arange(first, end, _SAMPLE_STEPS), end])
        positions = np.empty((len(steps), len(keyframe.sites), 3))
        for row, step in enumerate(steps):
            data.qpos[:] = qpos[step]
            mujoco.mj_kinematics(model, data)
            rotation = data.xmat[base].reshape(3, 3)
            for column, target in enumerate(keyframe.sites):
                site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, target.site)
                positions[row, column] = rotation.T @ (data.site_xpos[site] - data.xpos[base])
        for column, target in enumerate(keyframe.sites):
            asked = np.asarray(
                target.at_mm if target.frame == "base" else world_to_base_mm(target.at_mm)
            )
            reached = positions[:, column] * 1000
            worst = int(np.argmax(np.linalg.norm(reached - asked, axis=1)))
            out.append(
                SiteReach(
                    keyframe=keyframe.keyframe,
                    time_s=float(times_s[steps[worst]]),
                    site=target.site,
                    target_mm=tuple(float(v) for v in asked),  # type: ignore[arg-type]
                    reached_mm=tuple(float(v) for v in reached[worst]),  # type: ignore[arg-type]
                    where=target.where,
                )
            )
    return tuple(out)


SMALL_MOVE_MM = 20.0  # a site moving this little in space ...
LARGE_TURN_DEG = 45.0  # ... while a joint turns this much: a jump in joint space


@dataclass(frozen=True)
class JointJump:
    """A ``sites:`` keyframe whose small move in space IK could only meet with a large move in
    joints (another branch of the arm, or near a singularity)."""

    keyframe: int
    time_s: float
    site: str
    moved_mm: float  # the site's move from the keyframe before
    joint: str
    turned_deg: float  # that joint's move from the keyframe before
    where: SourceLocation


def joint_jumps(kin, due: Sequence[SitesDue], targets_deg, joint_names) -> tuple[JointJump, ...]:
    """Each played ``sites:`` keyframe against the one before (``targets_deg``: every played
    keyframe's joint targets): a site moving less than ``SMALL_MOVE_MM`` while a joint turns
    more than ``LARGE_TURN_DEG``."""
    out = []
    for keyframe in due:
        if keyframe.keyframe == 0:
            continue
        before = np.asarray(targets_deg[keyframe.keyframe - 1], dtype=float)
        after = np.asarray(targets_deg[keyframe.keyframe], dtype=float)
        turned = np.abs(after - before)
        if turned.max() <= LARGE_TURN_DEG:
            continue
        for target in keyframe.sites:
            moved = float(
                np.linalg.norm(
                    kin.site_pose(target.site, after).position_mm
                    - kin.site_pose(target.site, before).position_mm
                )
            )
            if moved < SMALL_MOVE_MM:
                j = int(np.argmax(turned))
                out.append(
                    JointJump(
                        keyframe.keyframe,
                        keyframe.arrival_s,
                        target.site,
                        moved,
                        joint_names[j],
                        float(turned[j]),
                        target.where,
                    )
                )
    return tuple(out)
