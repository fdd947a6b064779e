"""The pipeline from a loaded motion to what the servos are sent: plan
(``choreo.plan.planner``), then compile into ticks (``choreo.plan.ticks``). Play, preview and
validate all start from here."""

from __future__ import annotations

import os
from dataclasses import dataclass

from choreo.core.arguments import check_number
from choreo.motion.motion_file import Motion, motion_of
from choreo.plan.planner import Stretch, Trajectory, plan_motion
from choreo.plan.ticks import TOLERANCE_DEG, TickPlan, compile_ticks
from choreo.robot.types import Robot


@dataclass(frozen=True)
class CompiledMotion:
    """A motion planned and compiled into ticks: everything play, preview and validate need that
    doesn't depend on where the robot is now."""

    robot: Robot
    trajectory: Trajectory
    ticks: TickPlan
    stretches: tuple[Stretch, ...] = ()  # keyframes moved later to fit the limits (stretch=True)

    @property
    def tolerance_deg(self) -> float:
        return self.ticks.tolerance_deg


def compile_motion(
    motion: Motion | str | os.PathLike[str],
    *,
    speed: float | None = None,
    stretch: bool = False,
    tolerance_deg: float = 0.5,
) -> CompiledMotion:
    """``plan_motion`` then ``compile_ticks``: the ticks ``choreo play`` sends for ``motion`` (a
    :class:`Motion`, or its file's path). ``tolerance_deg``: how far the ticks may stray from
    the smooth plan, up to 5°."""
    motion = motion_of(motion)
    check_number("tolerance_deg", tolerance_deg, TOLERANCE_DEG)  # before the planning's work
    plan = plan_motion(motion, speed=speed, stretch=stretch)
    return CompiledMotion(
        motion.robot,
        plan.trajectory,
        compile_ticks(plan.trajectory, motion.robot, tolerance_deg=tolerance_deg),
        plan.stretches,
    )
