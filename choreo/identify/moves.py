"""The test moves one joint makes while the others hold: gentle, inside its limits, and each
chosen for what it shows.

- slow triangles: the output trails its set-point by the dead band, the play and the friction;
- small reversals (0.5° to 2.5°): the gear play swallows the small ones;
- steps at several move times (as fast as it goes, 150 ms, 400 ms): its speed, gain, torque and
  how late it starts;
- quick steps of 3° and 5°, as fast as it goes: the position loop rings on the joint's inertia
  without stalling, which tells its gain and its damping (so its torque) apart where gravity
  does not load the joint (a coxa, whose axis is upright: on its own the rest shows only their
  ratios);
- holds in several poses: the sag under gravity (its gain against the known load);
- slow triangles where gravity outweighs friction, only on a joint whose tests carry too little
  of it (``loaded_poses``): there the servo pulls the same way going up and down, so the two
  ways differ by the play and twice the friction over the gain but not the dead band, which
  lies in that difference everywhere else: friction and dead band come apart;
- a torque-off drop, only where the user said the joint can fall: the horn's offset (where
  gravity lets it rest), and friction without the motor.

A second, shorter set at other speeds, sizes and poses is held out: the fit never sees it, and
it tells how well the figures predict moves they were not fitted to.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from choreo.identify.joint_model import SentMove, Unload
from choreo.robot.types import Joint

if TYPE_CHECKING:
    from choreo.preview.joint_load import JointLoad

MARGIN_DEG = 5.0  # test moves keep this far inside the joint's limits
STEP_DEG = 20.0  # the largest step, where the range allows
HOLD_S = 0.6  # time to settle after a move, read all along
DROP_S = 0.4  # how long the torque stays off in a drop
GENTLE_DEG_S = 30.0  # from the pose the robot stands in to where the tests start
SLOW_DEG_S = 10.0  # the slowest triangles: friction and dead band, not speed
# the friction a servo may have, as a share of its stall torque (the bench's hidden truths go to
# 4 %; an LX servo's own is not published): where gravity on the tested range stays below it,
# holds and triangles show the dead band and twice the friction over the gain only as their sum
# (arm6's wrist_pitch, 0.026 N·m at its holds: one truth's friction came out +27 %), so loaded
# triangles are added where gravity reaches it, at most this far from the tests' centre
LOADED_SHARE = 0.04
LOADED_REACH_DEG = 60.0


@dataclass(frozen=True)
class MovePlan:
    """One joint's test: the commands (times from its start, angles in the servo's frame), how
    long to read, and its parts' names for progress."""

    commands: tuple[SentMove | Unload, ...]
    duration_s: float


class _Plan:
    def __init__(self, centre: float):
        self.t = 0.0
        self.at = centre
        self.commands: list[SentMove | Unload] = []

    def move(self, target: float, time_s: float, hold_s: float = HOLD_S) -> None:
        self.commands.append(SentMove(self.t, target, time_s))
        self.t += time_s + hold_s
        self.at = target

    def ramp(self, target: float, speed_deg_s: float) -> None:
        self.move(target, abs(target - self.at) / speed_deg_s, hold_s=0.0)

    def drop(self) -> None:
        self.commands.append(Unload(self.t))
        self.t += DROP_S

    def done(self) -> MovePlan:
        return MovePlan(tuple(self.commands), self.t)


def _gently(from_deg: float, to_deg: float) -> float:
    """The time to move to where the tests start (or to a loaded pose): at most
    GENTLE_DEG_S."""
    return max(0.3, abs(to_deg - from_deg) / GENTLE_DEG_S)


def centre_and_reach(joint: Joint, pose_deg: float) -> tuple[float, float]:
    """Where the tests centre (the pose, moved inside the limits if it must) and how far they
    may go either way."""
    low, high = joint.limits.min_deg + MARGIN_DEG, joint.limits.max_deg - MARGIN_DEG
    reach = min(STEP_DEG, max((high - low) / 2, 1.0))
    centre = min(max(pose_deg, low + reach), high - reach)
    return centre, reach


def _side(reach: float) -> float:
    """How far a hold is approached from, either way (and a loaded triangle goes)."""
    return min(3.0, reach / 4)


def loaded_poses(
    joint: Joint, pose_deg: float, load: JointLoad, stall_torque_nm: float
) -> tuple[float, ...]:
    """Where ``joint`` (its ``load`` and its servo's stall torque) needs slow triangles under
    gravity: none if gravity somewhere on the tested range already reaches ``LOADED_SHARE`` of
    the stall torque; else, on each side of the tests' centre within ``LOADED_REACH_DEG`` and
    the limits, the angle where gravity is largest, if it reaches that (a joint gravity never
    loads enough, a coxa, pays no bus time for it). The nearer to where the holds end first."""
    centre, reach = centre_and_reach(joint, pose_deg)
    needed = LOADED_SHARE * stall_torque_nm
    angles, gravity = load.angles_deg, np.abs(load.gravity_nm)
    tested = np.abs(angles - centre) <= reach
    if gravity[tested].max(initial=0.0) >= needed:
        return ()
    side = _side(reach)
    low = joint.limits.min_deg + MARGIN_DEG + side
    high = joint.limits.max_deg - MARGIN_DEG - side
    poses = []
    for direction in (1.0, -1.0):
        away = direction * (angles - centre)
        allowed = (away > 0) & (away <= LOADED_REACH_DEG) & (angles >= low) & (angles <= high)
        if allowed.any():
            best = int(np.flatnonzero(allowed)[np.argmax(gravity[allowed])])
            if gravity[best] >= needed:
                poses.append(float(angles[best]))
    holds_end = centre + reach - side
    return tuple(sorted(poses, key=lambda pose: abs(pose - holds_end)))


def fit_moves(
    joint: Joint, pose_deg: float, drop: bool = False, loaded: tuple[float, ...] = ()
) -> MovePlan:
    """The moves the figures are fitted to; ``loaded``: where to add slow triangles under
    gravity (``loaded_poses``)."""
    centre, reach = centre_and_reach(joint, pose_deg)
    plan = _Plan(centre)
    plan.move(centre, _gently(pose_deg, centre), hold_s=0.3)
    small = min(6.0, reach)
    for speed in (SLOW_DEG_S, 30.0):  # slow triangles
        plan.ramp(centre + small, speed)
        plan.ramp(centre - small, speed)
        plan.ramp(centre, speed)
    base = centre + min(2.0, reach / 2)
    plan.move(base, 0.2, hold_s=0.3)
    for size in (0.5, 1.0, 2.0):  # small reversals
        size = min(size, reach / 2)
        plan.move(base - size, 0.1, hold_s=0.3)
        plan.move(base, 0.1, hold_s=0.3)
    for time_s in (0.0, 0.15, 0.4):  # steps at several move times, both ways
        plan.move(centre + reach, time_s, hold_s=0.45)
        plan.move(centre - reach, time_s, hold_s=0.45)
    plan.move(centre, 0.2, hold_s=0.3)
    for size in (3.0, 5.0):  # quick steps the gain can follow without stalling: its ringing
        size = min(size, reach / 2)
        for target in (centre + size, centre, centre - size, centre):
            plan.move(target, 0.0, hold_s=0.3)
    side = _side(reach)  # holds, from either side
    for pose in (centre - reach + side, centre, centre + reach - side):
        plan.move(pose - side, 0.2, hold_s=0.1)
        plan.move(pose, 0.1, hold_s=0.3)
        plan.move(pose + side, 0.2, hold_s=0.1)
        plan.move(pose, 0.1, hold_s=0.3)
    for pose in loaded:  # slow triangles where gravity outweighs friction
        plan.move(pose - side, _gently(plan.at, pose - side), hold_s=0.1)
        plan.ramp(pose + side, SLOW_DEG_S)
        plan.ramp(pose - side, SLOW_DEG_S)
        plan.ramp(pose, SLOW_DEG_S)
    if loaded:
        plan.move(centre, _gently(plan.at, centre), hold_s=0.3)
    if drop:
        plan.move(centre, 0.3)
        plan.drop()
        plan.move(centre, 0.6)
    plan.move(centre, 0.3, hold_s=0.2)
    return plan.done()


def held_out_moves(joint: Joint, pose_deg: float) -> MovePlan:
    """Moves the fit never sees: another triangle speed, another step size and time, another
    pose."""
    centre, reach = centre_and_reach(joint, pose_deg)
    plan = _Plan(centre)
    plan.move(centre, _gently(pose_deg, centre), hold_s=0.3)
    plan.ramp(centre + reach * 0.6, 20.0)
    plan.ramp(centre - reach * 0.6, 20.0)
    plan.ramp(centre, 20.0)
    for target in (centre + reach * 0.75, centre - reach * 0.4, centre + reach * 0.3):
        plan.move(target, 0.25, hold_s=0.4)
    plan.move(centre + 1.2, 0.1, hold_s=0.3)
    plan.move(centre, 0.1, hold_s=0.3)
    return plan.done()
