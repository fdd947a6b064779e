"""One ruckig segment: limits, the solve, the joints that overshoot, and ruckig's failures."""

import numpy as np
import pytest
from plan_helpers import make_robot, ruckig_rest_to_rest

from choreo.plan.segment import (
    Limits,
    NoTrajectory,
    SegmentSolver,
    failing_joint,
    segment_ranges,
)


def test_limits_scale_every_joint_and_the_velocity_alone_by_its_own_factor():
    robot = make_robot(2, vel=300.0, acc=3000.0, jerk=30000.0)
    limits = Limits.of(robot, scale=0.5, velocity_scale=0.2)
    assert limits == Limits([30.0, 30.0], [1500.0, 1500.0], [15000.0, 15000.0])


def test_a_rest_to_rest_segment_takes_ruckigs_own_time_and_overshoots_nothing():
    robot = make_robot(2)
    start, target = [0.0, 0.0], [50.0, -20.0]
    low, high = segment_ranges(np.array([start, target]))
    profile = SegmentSolver(2).solve(
        start, [0.0, 0.0], target, [0.0, 0.0], Limits.of(robot), None, low[0], high[0]
    )
    assert profile.duration_s == pytest.approx(ruckig_rest_to_rest(robot, start, target).duration)
    assert profile.overshoot == []
    assert len(profile.phase_s) == len(profile.jerk) == 2 * 7  # seven phases per joint


def test_a_pass_through_velocity_that_carries_a_joint_past_its_target_is_named():
    robot = make_robot(2)
    start, target = [0.0, 0.0], [10.0, 40.0]
    low, high = segment_ranges(np.array([start, target]))
    profile = SegmentSolver(2).solve(  # j0 arrives fast and must turn back
        start, [0.0, 0.0], target, [250.0, 0.0], Limits.of(robot), None, low[0], high[0]
    )
    assert profile.overshoot == [0]


def test_a_minimum_duration_lengthens_the_segment():
    robot = make_robot(1)
    solver = SegmentSolver(1)
    shortest = solver.duration_s([0.0], [0.0], [30.0], [0.0], Limits.of(robot), None)
    assert solver.duration_s([0.0], [0.0], [30.0], [0.0], Limits.of(robot), 2.0) == (
        pytest.approx(2.0)
    )
    assert shortest < 2.0


def test_one_solver_takes_each_segments_own_limits_as_a_fresh_one_does():
    robot = make_robot(2)
    full, slow = Limits.of(robot), Limits.of(robot, velocity_scale=0.2)
    move = ([0.0, 0.0], [0.0, 0.0], [50.0, -20.0], [0.0, 0.0])
    reused = SegmentSolver(2)
    durations = [reused.duration_s(*move, limits, None) for limits in (full, slow, slow, full)]
    fresh = [SegmentSolver(2).duration_s(*move, limits, None) for limits in (full, slow)]
    assert durations == fresh + fresh[::-1]
    assert durations[1] > durations[0]


def test_the_limiting_joint_is_the_one_whose_own_move_is_longest():
    robot = make_robot(3)
    solver = SegmentSolver(3)
    solver.duration_s([0.0] * 3, [0.0] * 3, [5.0, 60.0, -20.0], [0.0] * 3, Limits.of(robot), None)
    assert solver.limiting_joint() == 1


def test_ruckigs_failure_names_the_joint_that_fails_on_its_own():
    robot = make_robot(3)
    limits = Limits.of(robot)
    limits.acc[1] = 1e-300  # a number ruckig's numerics fail on, for j1 alone
    with pytest.raises(NoTrajectory) as caught:
        SegmentSolver(3).duration_s([0.0] * 3, [0.0] * 3, [10.0] * 3, [0.0] * 3, limits, None)
    assert caught.value.joint == 1
    message = caught.value.message(robot, [0.0] * 3, [10.0, 20.0, 30.0])
    assert message == (
        "ruckig found no trajectory for j1 from 0° to 20°, its numbers out of its range; check "
        "j1's velocity, acceleration and jerk limits in models/bot/robot.yaml"
    )


def test_a_failure_no_joint_has_on_its_own_names_none():
    robot = make_robot(2)
    assert failing_joint([0.0, 0.0], [0.0, 0.0], [10.0, 20.0], [0.0, 0.0], Limits.of(robot)) is None
    assert NoTrajectory(None).message(robot, [0.0, 0.0], [10.0, 20.0], " and x") == (
        "ruckig found no trajectory, its numbers out of its range; check the velocity, "
        "acceleration and jerk limits in models/bot/robot.yaml and x"
    )


def test_a_segments_range_is_between_its_two_keyframes_with_slack():
    low, high = segment_ranges(np.array([[0.0, 10.0], [5.0, -5.0], [5.0, 0.0]]))
    assert np.allclose(low, [[0.0, -5.0], [5.0, -5.0]], atol=1e-5)
    assert np.allclose(high, [[5.0, 10.0], [5.0, 0.0]], atol=1e-5)
    assert low[0][0] < 0.0 and high[0][0] > 5.0  # the slack widens the range a little
