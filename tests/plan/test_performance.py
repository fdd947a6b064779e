"""choreo.plan.performance: the approach from where the servos are into the first pose, then
the motion, as one tick list and one smooth plan (what the player plays and the preview shows)."""

from __future__ import annotations

import numpy as np
import pytest
from paths import REPO

from choreo.motion.motion_file import load_motion
from choreo.plan.approach import slow_approach
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion

WAVE = REPO / "motions" / "arm6" / "wave.yaml"


@pytest.fixture(scope="module")
def compiled():
    return compile_motion(load_motion(WAVE))


@pytest.fixture(scope="module")
def from_rest(compiled):
    return prepare(compiled, compiled.robot.pose_vector("rest"))


def test_the_approach_runs_from_the_measured_pose_into_the_first_pose(compiled, from_rest):
    robot = compiled.robot
    first_pose = compiled.trajectory.at(0.0)[0]
    start, end = from_rest.planned_deg(np.array([0.0, from_rest.approach_s]))
    np.testing.assert_allclose(start, robot.pose_vector("rest"), atol=1e-6)
    np.testing.assert_allclose(end, first_pose, atol=1e-6)
    assert from_rest.approach_s > 0


def test_the_approach_is_the_slow_approach_within_the_motions_tolerance(compiled, from_rest):
    robot = compiled.robot
    first_pose = compiled.trajectory.at(0.0)[0]
    approach = slow_approach(robot, robot.pose_vector("rest"), first_pose, compiled.tolerance_deg)
    assert from_rest.approach == approach.tick_plan
    assert from_rest.approach_trajectory.duration_s == approach.duration_s


def test_the_motion_ticks_follow_the_approach_ticks_without_a_gap(compiled, from_rest):
    ticks = from_rest.ticks
    approach = len(from_rest.approach.ticks)
    assert len(ticks) == approach + len(compiled.ticks.ticks)
    assert all(a.end_ms == b.start_ms for a, b in zip(ticks, ticks[1:]))
    offset = from_rest.approach.duration_ms
    assert [t.start_ms - offset for t in ticks[approach:]] == [
        t.start_ms for t in compiled.ticks.ticks
    ]
    assert ticks[approach:][0].targets_units == compiled.ticks.ticks[0].targets_units


def test_after_the_approach_the_plan_is_the_motions_shifted(compiled, from_rest):
    times = from_rest.approach_s + np.linspace(0, compiled.trajectory.duration_s, 50)
    np.testing.assert_allclose(
        from_rest.planned_deg(times),
        compiled.trajectory.positions(times - from_rest.approach_s),
        atol=1e-9,
    )


def test_from_the_first_pose_itself_the_approach_is_only_a_rest(compiled):
    first_pose = compiled.trajectory.at(0.0)[0]
    performance = prepare(compiled, first_pose)
    times = np.linspace(0, performance.approach_s, 20)
    np.testing.assert_allclose(performance.planned_deg(times), [first_pose] * 20, atol=1e-6)
