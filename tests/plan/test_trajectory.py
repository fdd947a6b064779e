"""choreo.plan.trajectory: the planned polynomials evaluate as ruckig's own trajectory does, however
they are sampled, and rest at the last pose after the end."""

from __future__ import annotations

import numpy as np
import pytest
from plan_helpers import POS_EPS, kf, make_motion, make_robot, ruckig_rest_to_rest

from choreo.plan.planner import plan_approach, plan_motion


# --- evaluation matches ruckig -----------------------------------------------------------------
def test_approach_samples_match_ruckig_at_time():
    robot = make_robot(4)
    start, target = [80.0, -85.0, 3.0, 0.0], [-10.0, 20.0, 3.0, 45.0]
    trajectory = plan_approach(robot, start, target, limit_scale=0.3)
    reference = ruckig_rest_to_rest(robot, start, target, scale=0.3)
    assert trajectory.duration_s == pytest.approx(reference.duration, abs=1e-12)
    times = np.linspace(0, reference.duration, 137)
    pos, vel, acc = trajectory.sample(times)
    for k, t in enumerate(times):
        p, v, a = reference.at_time(t)
        np.testing.assert_allclose(pos[k], p, atol=1e-9)
        np.testing.assert_allclose(vel[k], v, atol=1e-7)
        np.testing.assert_allclose(acc[k], a, atol=1e-5)
    assert trajectory.keyframe_times_s == (trajectory.duration_s,)


def test_sampling_unsorted_long_and_short_queries_agree():
    robot = make_robot(3)
    motion = make_motion(
        robot, [kf([0, 0, 0], 1), kf([40, -30, 20], 2, t=0.6), kf([-20, 10, 20], 3, t=1.2)]
    )
    trajectory = plan_motion(motion).trajectory
    times = np.linspace(0, trajectory.duration_s, 3001)
    pos, vel, _ = trajectory.sample(times)
    shuffled = np.random.default_rng(1).permutation(len(times))
    pos2, vel2, _ = trajectory.sample(times[shuffled])
    np.testing.assert_array_equal(pos2, pos[shuffled])
    np.testing.assert_array_equal(vel2, vel[shuffled])
    np.testing.assert_array_equal(trajectory.positions(times[:50]), pos[:50])
    np.testing.assert_array_equal(trajectory.at(times[1234])[0], pos[1234])


def test_peaks_are_the_sampled_maxima():
    robot = make_robot(3)
    motion = make_motion(robot, [kf([0, 0, 0], 1), kf([70, -30, 5], 2), kf([-60, 40, 5], 3)])
    trajectory = plan_motion(motion).trajectory
    _, vel, acc = trajectory.sample(np.linspace(0, trajectory.duration_s, 200001))
    np.testing.assert_allclose(trajectory.peak_velocity_deg_s(), np.abs(vel).max(axis=0), rtol=1e-4)
    np.testing.assert_allclose(
        trajectory.peak_acceleration_deg_s2(), np.abs(acc).max(axis=0), rtol=1e-3
    )


def test_after_the_end_the_robot_rests_and_before_the_start_is_an_error():
    robot = make_robot(2)
    trajectory = plan_motion(make_motion(robot, [kf([0, 0], 1), kf([30, -30], 2)])).trajectory
    pos, vel, _ = trajectory.sample(np.array([trajectory.duration_s + 5.0]))
    np.testing.assert_allclose(pos[0], [30, -30], atol=POS_EPS)
    np.testing.assert_array_equal(vel[0], [0, 0])
    with pytest.raises(ValueError, match=">= 0"):
        trajectory.sample(np.array([-0.1]))
