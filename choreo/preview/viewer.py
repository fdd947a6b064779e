"""MuJoCo's interactive viewer, replaying a rollout in real time (needs a display)."""

from __future__ import annotations

import os
import time

import mujoco
import numpy as np

from choreo.errors import PreviewError, Worded, joined
from choreo.preview.gl import window_system_problem
from choreo.preview.model import load_model
from choreo.preview.rollout import Rollout
from choreo.preview.simulated import SimulatedMotion, rollout_of

FRAME_S = 1 / 60
RENDER_INSTEAD = Worded("render to a file instead ({render_preview})", ("render_preview",))


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _cannot_view(problem: str) -> PreviewError:
    return PreviewError(joined("; ", (problem, RENDER_INSTEAD)))


def _check_window_system() -> None:
    """PreviewError (one line) if GLFW cannot reach the display: mujoco's viewer would print
    GLFW's warnings and exit the process instead."""
    problem = window_system_problem()
    if problem is not None:
        display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        raise _cannot_view(f"the viewer cannot open a window on display {display!r} ({problem})")


def show_in_viewer(rollout: SimulatedMotion | Rollout) -> None:
    """Loop the rollout (``simulate_motion``'s, or ``simulate``'s) in the viewer until its window
    is closed."""
    recorded = rollout_of(rollout)
    # mujoco's viewer kills the whole process when it cannot open a window: check first
    if not has_display():
        raise _cannot_view(
            "the viewer needs a display and neither DISPLAY nor WAYLAND_DISPLAY is set"
        )
    _check_window_system()
    from mujoco import viewer as mujoco_viewer  # needs GLFW: imported only with a display

    model = load_model(recorded.robot, recorded.props)
    data = mujoco.MjData(model)
    with mujoco_viewer.launch_passive(model, data) as viewer:
        started = time.monotonic()
        while viewer.is_running():
            span = recorded.duration_s - recorded.start_s
            t = recorded.start_s + ((time.monotonic() - started) % span if span else 0.0)
            step = min(int(np.searchsorted(recorded.times_s, t)), len(recorded.times_s) - 1)
            data.qpos[:] = recorded.qpos[step]
            mujoco.mj_forward(model, data)
            viewer.sync()
            time.sleep(FRAME_S)
