"""Preview a motion in MuJoCo: what the servos will really do with the ticks they receive,
checked for problems and rendered offscreen.

    rollout = simulate_motion(motion)          # start pose -> approach -> the motion's ticks
    results = run_checks(rollout)              # collisions, limits, stalls, tracking, falls
    render_preview(rollout, "out.mp4", results=results)

The package is the only place besides ``choreo.robot.model_check`` (the robot loader's MJCF checks)
that imports ``mujoco``.
"""

from __future__ import annotations

from choreo.motion.motion_file import HOME_POSE, Motion
from choreo.motion.scene import StartPosture
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.preview.actuator import ActuatorParams, actuator_params
from choreo.preview.checks import (
    CheckKind,
    CheckResult,
    CheckThresholds,
    Severity,
    run_checks,
)
from choreo.preview.render import (
    RenderResult,
    RenderSettings,
    frame_times,
    render_frames,
    render_preview,
)
from choreo.preview.report import (
    JointSummary,
    busiest_line,
    joint_summaries,
    preview_report,
    start_lines,
)
from choreo.preview.sim import MoveStart, Rollout, Settling, SimSettings, simulate
from choreo.preview.travel import BodyTravel, body_travel
from choreo.preview.viewer import has_display, show_in_viewer

FIRST_KEYFRAME = "first"  # start pose name meaning the motion's first keyframe

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
    "Settling",
    "SimSettings",
    "actuator_params",
    "busiest_line",
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
    "start_pose_deg",
    "start_lines",
    "FIRST_KEYFRAME",
]


def simulate_motion(
    motion: Motion,
    settings: SimSettings | None = None,
    *,
    speed: float | None = None,
    stretch: bool = False,
    tolerance_deg: float = 0.5,
    start_pose: str | None = None,
) -> Rollout:
    """Plan ``motion`` and compile it into ticks as ``choreo play`` does (same options), add the
    approach the player would play from the start pose, and play it all to the simulated robot.

    The start pose is the robot's pose ``start_pose``, or "first" for the motion's first
    keyframe; by default ``home`` (the first keyframe for a motion that starts lying, or a
    robot without a home pose).
    """
    compiled = compile_motion(motion, speed=speed, stretch=stretch, tolerance_deg=tolerance_deg)
    start_deg = start_pose_deg(motion, compiled.trajectory.at(0.0)[0], start_pose)
    performance = prepare(compiled, start_deg)
    return simulate(
        motion.robot,
        performance.ticks,
        start_deg,
        keyframe_times_s=compiled.trajectory.keyframe_times_s,
        settings=settings or SimSettings(),
        motion_start_s=performance.approach_s,
        posture=motion.start,
        props=motion.props,
    )


def start_pose_deg(motion: Motion, first_deg, start_pose: str | None) -> tuple[float, ...]:
    """Where the robot is before the approach (see ``simulate_motion``)."""
    robot = motion.robot
    if start_pose is None:
        lying = motion.start is not StartPosture.STANDING
        start_pose = "first" if lying or HOME_POSE not in robot.poses else HOME_POSE
    if start_pose == FIRST_KEYFRAME:
        return tuple(float(a) for a in first_deg)
    if start_pose not in robot.poses:
        raise ValueError(
            f"no pose {start_pose!r} in {robot.path}; start from one of "
            f"{', '.join([*robot.poses, FIRST_KEYFRAME])}"
        )
    return robot.pose_vector(start_pose)
