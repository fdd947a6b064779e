"""choreo.plan.approach: the one slow move from wherever the servos stand to a pose."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.plan.approach import slow_approach
from choreo.plan.planner import APPROACH_LIMIT_SCALE
from choreo.plan.ticks import QUANTIZATION_DEG
from choreo.robot.robot_file import load_robot


@pytest.fixture(scope="module")
def arm():
    return load_robot("arm6")


def test_the_approach_moves_at_a_share_of_every_joint_limit(arm):
    approach = slow_approach(arm, arm.pose_vector("rest"), arm.pose_vector("home"))
    times = np.linspace(0, approach.duration_s, 400)
    _, velocity, _ = approach.trajectory.sample(times)
    limits = np.array([j.limits.vel_deg_s for j in arm.joints])
    assert approach.duration_s > 0
    assert np.all(np.abs(velocity) <= APPROACH_LIMIT_SCALE * limits + 1e-6)


@pytest.mark.parametrize("tolerance_deg", [0.25, 2.0])
def test_its_ticks_run_from_start_to_target_within_the_tolerance(arm, tolerance_deg):
    start, target = arm.pose_vector("rest"), arm.pose_vector("home")
    approach = slow_approach(arm, start, target, tolerance_deg)
    plan = approach.tick_plan
    assert plan.tolerance_deg == tolerance_deg
    assert plan.max_deviation_deg <= tolerance_deg + QUANTIZATION_DEG
    assert plan.duration_ms >= approach.duration_s * 1000
    last = [j.to_deg(u) for j, u in zip(arm.joints, plan.ticks[-1].targets_units)]
    np.testing.assert_allclose(last, target, atol=QUANTIZATION_DEG + 1e-6)


def test_a_finer_tolerance_takes_more_ticks(arm):
    start, target = arm.pose_vector("rest"), arm.pose_vector("home")
    coarse = slow_approach(arm, start, target, 2.0).tick_plan
    fine = slow_approach(arm, start, target, 0.25).tick_plan
    assert len(fine.ticks) > len(coarse.ticks)
