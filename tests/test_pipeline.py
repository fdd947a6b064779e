"""choreo.plan.pipeline: a loaded motion -> planned -> ticks, with what play and preview need."""

from __future__ import annotations

import numpy as np

from choreo.motion.motion_file import load_motion
from choreo.plan.pipeline import compile_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import compile_ticks

WAVE = "motions/arm6/wave.yaml"


def test_compiling_is_planning_then_segmenting_with_the_options_passed_on():
    motion = load_motion(WAVE)
    compiled = compile_motion(motion, speed=0.5, tolerance_deg=0.25)
    plan = plan_motion(motion, speed=0.5)
    assert compiled.robot is motion.robot
    assert compiled.tolerance_deg == 0.25
    assert compiled.trajectory.duration_s == plan.trajectory.duration_s
    times = np.linspace(0, plan.trajectory.duration_s, 50)
    assert np.array_equal(compiled.trajectory.positions(times), plan.trajectory.positions(times))
    assert compiled.ticks == compile_ticks(plan.trajectory, motion.robot, tolerance_deg=0.25)
    assert compiled.stretches == ()
