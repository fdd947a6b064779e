"""choreo.plan.pipeline: a loaded motion -> planned -> ticks, with what play and preview need."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.errors import OptionError
from choreo.motion.motion_file import load_motion
from choreo.plan.pipeline import PlanOptions, compile_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import DEFAULT_TOLERANCE_DEG, compile_ticks

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


def test_the_collector_waits_while_a_motion_is_planned_and_compiled(monkeypatch):
    import gc

    import choreo.plan.pipeline as pipeline

    seen = []
    for name in ("plan_motion", "compile_ticks"):
        step = getattr(pipeline, name)
        monkeypatch.setattr(
            pipeline, name, lambda *a, step=step, **k: seen.append(gc.isenabled()) or step(*a, **k)
        )
    compile_motion(load_motion(WAVE))
    assert seen == [False, False]
    assert gc.isenabled()


def test_plan_options_are_taken_whole_or_as_separate_arguments_never_both():
    motion = load_motion(WAVE)
    whole = compile_motion(motion, PlanOptions(speed=0.5, tolerance_deg=0.25))
    assert whole.ticks == compile_motion(motion, speed=0.5, tolerance_deg=0.25).ticks
    with pytest.raises(OptionError) as refused:
        compile_motion(motion, PlanOptions(speed=0.5), tolerance_deg=0.25)
    assert refused.value.option == "plan"
    assert "put them in plan" in str(refused.value)


def test_plan_options_check_each_setting_by_its_name():
    assert PlanOptions() == PlanOptions(None, False, DEFAULT_TOLERANCE_DEG)
    for arguments, option in (
        (dict(speed=0), "speed"),
        (dict(stretch="yes"), "stretch"),
        (dict(tolerance_deg=5.01), "tolerance_deg"),
    ):
        with pytest.raises(OptionError) as refused:
            PlanOptions(**arguments)
        assert refused.value.option == option
