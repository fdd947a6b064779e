"""The shipped motions (motions/), each loaded and simulated at most once in a test process.

Their simulations take seconds each (a hexapod's several), and more than one file checks them:
tests/preview/test_preview_shipped.py that every one passes every check,
tests/preview/test_start.py how they start, tests/preview/test_travel.py where the walkers go,
tests/preview/test_walk.py how their gaits did, tests/preview/test_render.py and
test_render_follow.py how the camera frames them. Loading a walker's motion solves its gaits'
feet (side_step: ~0.6 s), and tests/robot/test_models.py checks every loaded motion's poses
too. Those files run on one worker of a parallel run (tests/conftest.py) and share these
results; nothing may change a result it is given."""

from __future__ import annotations

import functools
from pathlib import Path

from paths import REPO

from choreo.motion.motion_file import Motion, load_motion
from choreo.preview import SimulatedMotion, simulate_motion

SHIPPED_MOTIONS = sorted((REPO / "motions").glob("*/*.yaml"))


@functools.cache
def loaded_shipped(path: Path) -> Motion:
    """``load_motion`` of the shipped motion at ``path``."""
    assert path in SHIPPED_MOTIONS, f"{path} is not a shipped motion"
    return load_motion(path)


@functools.cache
def simulated_shipped(path: Path) -> SimulatedMotion:
    """``simulate_motion`` of the shipped motion at ``path``, with the default settings."""
    return simulate_motion(loaded_shipped(path))
