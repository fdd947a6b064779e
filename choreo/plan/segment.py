"""One ruckig segment: the moves between two keyframes, every joint leaving and arriving together
(the only module that imports ruckig).

Facts about ruckig 0.19.4 this relies on: ``minimum_duration`` silently lengthens a segment that
cannot be done in the time asked (the planner compares durations itself); intermediate waypoints
call a cloud service (never used: one calculation per interval); the result is read back as seven
constant-jerk phases per joint, which ``Trajectory`` evaluates with numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, RuckigError, Synchronization
from ruckig import Trajectory as RuckigTrajectory

from choreo.plan.trajectory import Profile
from choreo.robot.types import Robot

DURATION_EPS_S = 1e-6  # ruckig's durations match a requested one to ~1e-12 s
POSITION_EPS_DEG = 1e-6  # numerical slack when checking for overshoot


@dataclass(frozen=True)
class Limits:
    """Per-joint limits as plain lists (what ruckig takes)."""

    vel: list[float]
    acc: list[float]
    jerk: list[float]

    @staticmethod
    def of(robot: Robot, scale: float = 1.0, velocity_scale: float = 1.0) -> Limits:
        lim = [j.limits for j in robot.joints]
        return Limits(
            [x.vel_deg_s * scale * velocity_scale for x in lim],
            [x.acc_deg_s2 * scale for x in lim],
            [x.jerk_deg_s3 * scale for x in lim],
        )


class NoTrajectory(Exception):
    """ruckig found no trajectory for a segment (limits or times too extreme for its numerics):
    ``joint`` the index of the joint that fails on its own, if one does. The planner says which
    keyframe's move it was. ruckig's own text (its step, its input dump) is not a user's: it is
    kept as the exception's cause only."""

    def __init__(self, joint: int | None):
        super().__init__(f"no trajectory (joint {joint})")
        self.joint = joint

    def message(
        self, robot: Robot, p0: Sequence[float], p1: Sequence[float], also_check: str = ""
    ) -> str:
        """What failed, from ``p0`` to ``p1`` (degrees, every joint), and what to check (the
        limits, and ``also_check``)."""
        if self.joint is None:
            return (
                f"ruckig found no trajectory, its numbers out of its range; check the velocity, "
                f"acceleration and jerk limits in {robot.path}{also_check}"
            )
        name = robot.joint_names[self.joint]
        return (
            f"ruckig found no trajectory for {name} from {p0[self.joint]:g}° to "
            f"{p1[self.joint]:g}°, its numbers out of its range; check {name}'s velocity, "
            f"acceleration and jerk limits in {robot.path}{also_check}"
        )


class SegmentSolver:
    """Reuses one ruckig instance for every segment of a plan."""

    def __init__(self, n_joints: int):
        self._ruckig = Ruckig(n_joints)
        self._input = InputParameter(n_joints)
        self._input.synchronization = Synchronization.Time
        self._input.current_acceleration = self._input.target_acceleration = [0.0] * n_joints
        self._output = RuckigTrajectory(n_joints)
        self._limits: Limits | None = None  # those in the input now (set only when they change)

    def duration_s(
        self,
        p0: list[float],
        v0: list[float],
        p1: list[float],
        v1: list[float],
        limits: Limits,
        minimum_duration_s: float | None,
    ) -> float:
        inp = self._input
        inp.current_position = p0
        inp.current_velocity = v0
        inp.target_position = p1
        inp.target_velocity = v1
        if limits is not self._limits:  # the same for most segments of a plan
            inp.max_velocity = limits.vel
            inp.max_acceleration = limits.acc
            inp.max_jerk = limits.jerk
            self._limits = limits
        inp.minimum_duration = minimum_duration_s
        try:
            result = self._ruckig.calculate(inp, self._output)
        except (RuckigError, ValueError) as error:  # ValueError: a code Result doesn't list
            raise NoTrajectory(failing_joint(p0, v0, p1, v1, limits)) from error
        if result != Result.Working:
            raise NoTrajectory(failing_joint(p0, v0, p1, v1, limits))
        return self._output.duration

    def solve(
        self,
        p0: list[float],
        v0: list[float],
        p1: list[float],
        v1: list[float],
        limits: Limits,
        minimum_duration_s: float | None,
        low: list[float],
        high: list[float],
    ) -> Profile:
        """The segment; ``overshoot`` lists the joints leaving ``low..high`` (the range between
        the two keyframes, widened by a numerical margin)."""
        duration = self.duration_s(p0, v0, p1, v1, limits, minimum_duration_s)
        out = self._output
        overshoot = [
            j
            for j, (e, lo, hi) in enumerate(zip(out.position_extrema, low, high))
            if e.min < lo or e.max > hi
        ]
        phase_s: list[float] = []
        jerk: list[float] = []
        for profile in out.profiles[0]:
            phase_s += profile.t
            jerk += profile.j
        return Profile(p0, v0, duration, phase_s, jerk, overshoot)

    def limiting_joint(self) -> int:
        """The joint whose own shortest duration is longest, in the last segment solved."""
        return int(np.argmax(self._output.independent_min_durations))


def failing_joint(
    p0: Sequence[float],
    v0: Sequence[float],
    p1: Sequence[float],
    v1: Sequence[float],
    limits: Limits,
) -> int | None:
    """The first joint ruckig finds no trajectory for on its own (None: each has one alone).
    Found by trying each, not read from ruckig's message, whose wording is its own to change."""
    solver, alone, output = Ruckig(1), InputParameter(1), RuckigTrajectory(1)
    for j in range(len(p0)):
        alone.current_position, alone.current_velocity = [p0[j]], [v0[j]]
        alone.target_position, alone.target_velocity = [p1[j]], [v1[j]]
        alone.current_acceleration = alone.target_acceleration = [0.0]
        alone.max_velocity, alone.max_acceleration = [limits.vel[j]], [limits.acc[j]]
        alone.max_jerk = [limits.jerk[j]]
        try:
            if solver.calculate(alone, output) != Result.Working:
                return j
        except (RuckigError, ValueError):
            return j
    return None


def segment_ranges(positions: np.ndarray) -> tuple[list[list[float]], list[list[float]]]:
    """Per segment, the range each joint must stay in: between its two keyframes."""
    low = np.minimum(positions[:-1], positions[1:]) - POSITION_EPS_DEG
    high = np.maximum(positions[:-1], positions[1:]) + POSITION_EPS_DEG
    return low.tolist(), high.tolist()
