"""Preview a motion in MuJoCo: what the servos will really do with the ticks they receive,
checked for problems and rendered offscreen::

    simulated = simulate_motion(motion)        # start pose -> approach -> the motion's ticks
    results = run_checks(simulated)            # collisions, limits, stalls, tracking, falls
    render_preview(simulated, "out.mp4", results=results)

- :mod:`~choreo.preview.pipeline`: :func:`simulate_motion`, a motion planned, compiled, played
  to the simulated robot from its start pose and measured (its ``Rehearsal``, ``rehearsal_of``:
  the ticks from the start pose, without the physics);
- :mod:`~choreo.preview.sim`: :func:`simulate`, ticks in, a :class:`Rollout` out
  (:mod:`~choreo.preview.rollout`): what the simulation recorded; ``model``, ``actuator`` and
  ``start`` make the robot, its servos and its start for it, ``step_loop`` steps and checkpoints
  it, ``contact_log`` logs its touches;
- :mod:`~choreo.preview.simulated`: :class:`SimulatedMotion`, a rollout with what was measured on
  it: ``travel`` (the body), ``props``, ``walk`` (a walker's stance; ``stance``) and its gaits,
  ``reach`` (``sites:`` targets), ``impact`` (how a robot that ends lying comes down);
- :mod:`~choreo.preview.checks`: :func:`run_checks`, what would go wrong on the robot (the servos'
  checks in :mod:`~choreo.preview.servo_checks`, the body's in :mod:`~choreo.preview.body_checks`;
  a finding and the thresholds, :mod:`~choreo.preview.findings`);
- :mod:`~choreo.preview.report`: the ``--report`` JSON and the lines the CLI prints;
- :mod:`~choreo.preview.render`, ``gl``, ``viewer``: pictures, offscreen or in a window.

The package is the only place besides ``choreo.robot.model_check`` (the robot loader's MJCF checks)
that imports ``mujoco``.
"""

from __future__ import annotations

from choreo.preview.actuator import ActuatorParams, actuator_params
from choreo.preview.checks import run_checks
from choreo.preview.findings import CheckKind, CheckResult, CheckThresholds, Severity
from choreo.preview.pipeline import (
    FIRST_KEYFRAME,
    Rehearsal,
    rehearsal_of,
    simulate_motion,
    simulate_rehearsal,
    start_pose_deg,
)
from choreo.preview.props import PropOutcome, prop_outcomes
from choreo.preview.reach import REACH_ERROR_MM, REACH_WARNING_MM, JointJump, SiteReach
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
    reach_line,
    start_lines,
)
from choreo.preview.rollout import MoveStart, Rollout, Settling
from choreo.preview.sim import SimSettings, simulate
from choreo.preview.simulated import SimulatedMotion
from choreo.preview.step_loop import Resume
from choreo.preview.travel import BodyTravel, body_travel
from choreo.preview.viewer import has_display, show_in_viewer
from choreo.preview.walk import GaitOutcome, Walk, gait_outcomes

__all__ = [
    "ActuatorParams",
    "BodyTravel",
    "CheckKind",
    "CheckResult",
    "CheckThresholds",
    "FIRST_KEYFRAME",
    "GaitOutcome",
    "JointJump",
    "JointSummary",
    "MoveStart",
    "PropOutcome",
    "REACH_ERROR_MM",
    "REACH_WARNING_MM",
    "Rehearsal",
    "RenderResult",
    "RenderSettings",
    "Resume",
    "Rollout",
    "Settling",
    "Severity",
    "SimSettings",
    "SimulatedMotion",
    "SiteReach",
    "Walk",
    "actuator_params",
    "body_travel",
    "busiest_line",
    "frame_times",
    "gait_outcomes",
    "has_display",
    "joint_summaries",
    "preview_report",
    "prop_outcomes",
    "reach_line",
    "rehearsal_of",
    "render_frames",
    "render_preview",
    "run_checks",
    "show_in_viewer",
    "simulate",
    "simulate_motion",
    "simulate_rehearsal",
    "start_lines",
    "start_pose_deg",
]
