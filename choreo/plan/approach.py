"""The slow approach: from wherever the servos stand, at rest, to a pose, at rest, at
``APPROACH_LIMIT_SCALE`` of every joint's limits, as ticks. The one move choreo makes from a
pose it did not plan: into a motion's first pose (the performance), to the exit pose (the
player), to a pose the studio's page asks for; a vendor file's first row lasts as long (d6a)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from choreo.plan.planner import APPROACH_LIMIT_SCALE, plan_approach
from choreo.plan.ticks import DEFAULT_TOLERANCE_DEG, TickPlan, compile_ticks
from choreo.plan.trajectory import Trajectory
from choreo.robot.types import Robot


@dataclass(frozen=True)
class Approach:
    trajectory: Trajectory
    tick_plan: TickPlan  # within the tolerance it was made with

    @property
    def duration_s(self) -> float:
        return self.trajectory.duration_s


def slow_approach(
    robot: Robot,
    start_deg: Sequence[float] | np.ndarray,
    target_deg: Sequence[float] | np.ndarray,
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
) -> Approach:
    """The approach from ``start_deg`` (where the servos are; may lie outside the joint limits)
    to ``target_deg``, and its ticks within ``tolerance_deg``."""
    trajectory = plan_approach(robot, start_deg, target_deg, APPROACH_LIMIT_SCALE)
    return Approach(trajectory, compile_ticks(trajectory, robot, tolerance_deg=tolerance_deg))
