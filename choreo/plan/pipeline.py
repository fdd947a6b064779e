"""The pipeline from a loaded motion to what the servos are sent: plan
(``choreo.plan.planner``), then compile into ticks (``choreo.plan.ticks``), as
:class:`PlanOptions` say. Play, preview and validate all start from here."""

from __future__ import annotations

import os
from dataclasses import dataclass

from choreo.core.arguments import check_flag, check_number, check_optional_number, check_type
from choreo.core.collector import collector_paused
from choreo.errors import OptionError
from choreo.motion.motion_file import Motion, motion_of
from choreo.motion.timing import SPEED
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import DEFAULT_TOLERANCE_DEG, TOLERANCE_DEG, TickPlan, compile_ticks
from choreo.plan.trajectory import Stretch, Trajectory
from choreo.robot.types import Robot


@dataclass(frozen=True)
class PlanOptions:
    """How a motion is planned and compiled, the same for play, preview and plan: its ``speed``
    (None: the file's), ``stretch`` (move keyframes the servos cannot reach in time later
    instead of failing), and how far the ticks may stray from the smooth plan (up to 5°).
    Each is checked here (``OptionError`` naming it)."""

    speed: float | None = None
    stretch: bool = False
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG

    def __post_init__(self) -> None:
        check_optional_number("speed", self.speed, SPEED)
        check_flag("stretch", self.stretch)
        check_number("tolerance_deg", self.tolerance_deg, TOLERANCE_DEG)


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
    plan: PlanOptions | None = None,
    *,
    speed: float | None = None,
    stretch: bool = False,
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
) -> CompiledMotion:
    """``plan_motion`` then ``compile_ticks``: the ticks ``choreo play`` sends for ``motion`` (a
    :class:`Motion`, or its file's path), as ``plan`` says, or without it ``speed``,
    ``stretch`` and ``tolerance_deg`` (see :class:`PlanOptions`)."""
    motion = motion_of(motion)
    plan = plan_options(plan, speed, stretch, tolerance_deg)  # checked before the planning's work
    with collector_paused():  # segments, profiles and ticks: many objects, no cycles
        result = plan_motion(motion, speed=plan.speed, stretch=plan.stretch)
        ticks = compile_ticks(result.trajectory, motion.robot, tolerance_deg=plan.tolerance_deg)
    return CompiledMotion(motion.robot, result.trajectory, ticks, result.stretches)


def plan_options(
    plan: PlanOptions | None, speed: object, stretch: object, tolerance_deg: object
) -> PlanOptions:
    """``plan``, or one made of the separate arguments a call also takes; both at once is
    refused (one of them would be lost)."""
    if plan is None:
        return PlanOptions(speed, stretch, tolerance_deg)  # type: ignore[arg-type]  # checked
    check_type("plan", plan, PlanOptions, "a PlanOptions, e.g. PlanOptions(speed=2), or None")
    if (speed, stretch, tolerance_deg) != (None, False, DEFAULT_TOLERANCE_DEG):
        raise OptionError(
            "plan", "is given with speed, stretch or tolerance_deg beside it: put them in plan"
        )
    return plan
