"""Preview a motion in MuJoCo: what the servos will really do with the ticks they receive,
checked for problems and rendered offscreen.

    rollout = simulate_motion(motion)          # plan -> segment -> simulate the tick stream
    results = run_checks(rollout)              # collisions, limits, stalls, tracking, falls
    render_preview(rollout, "out.mp4", results=results)

The package is the only place besides the robot loader that imports ``mujoco``.
"""

from __future__ import annotations

from ..motion import Motion
from ..segments import compile_motion
from .checks import (
    CheckKind,
    CheckResult,
    CheckThresholds,
    Severity,
    run_checks,
)
from .render import RenderResult, RenderSettings, frame_times, render_frames, render_preview
from .report import JointSummary, joint_summaries, preview_report
from .servo import ActuatorParams, actuator_params
from .sim import MoveStart, Rollout, SimSettings, simulate
from .travel import BodyTravel, body_travel
from .viewer import has_display, show_in_viewer

__all__ = [
    "ActuatorParams",
    "BodyTravel",
    "CheckKind",
    "CheckResult",
    "CheckThresholds",
    "JointSummary",
    "MoveStart",
    "RenderResult",
    "RenderSettings",
    "Rollout",
    "Severity",
    "SimSettings",
    "actuator_params",
    "body_travel",
    "frame_times",
    "has_display",
    "joint_summaries",
    "preview_report",
    "render_frames",
    "render_preview",
    "run_checks",
    "show_in_viewer",
    "simulate",
    "simulate_motion",
]


def simulate_motion(
    motion: Motion,
    settings: SimSettings = SimSettings(),
    *,
    speed: float | None = None,
    stretch: bool = False,
    tolerance_deg: float = 0.5,
) -> Rollout:
    """Plan ``motion`` and compile it into ticks as ``choreo play`` does (same options), then
    play them to the simulated robot, starting at rest at the motion's first pose."""
    compiled = compile_motion(motion, speed=speed, stretch=stretch, tolerance_deg=tolerance_deg)
    trajectory = compiled.trajectory
    return simulate(
        motion.robot,
        compiled.ticks.ticks,
        trajectory.at(0.0)[0],
        keyframe_times_s=trajectory.keyframe_times_s,
        settings=settings,
    )
