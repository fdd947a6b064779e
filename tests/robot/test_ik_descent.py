"""The IK's damped least squares on arrays: a step held inside the joint limits, the pitch target,
the cross product it uses, and a descent on a task whose Jacobian is known."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.robot.ik_descent import (
    Attempts,
    Poses,
    Task,
    axis_with_pitch,
    cross,
    descend,
    limited_step,
)


def test_the_cross_product_is_numpys_broadcast():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(4, 1, 3)), rng.normal(size=(5, 3))
    assert np.allclose(cross(a, b), np.cross(a, b))


def test_a_joint_at_a_limit_the_step_would_push_past_is_held_out_of_it():
    jacobian = np.eye(2)[None]  # each joint moves one residual row
    residual = np.array([[-0.1, 0.1]])  # both would go down then up
    q = np.array([[0.0, 0.0]])
    low, high = np.array([0.0, -1.0]), np.array([1.0, 1.0])
    step = limited_step(jacobian, residual, q, low, high, np.array([1e-6]))
    assert step[0, 0] == 0.0  # at its lower limit: held
    assert step[0, 1] == pytest.approx(0.1, rel=1e-4)


def test_a_step_is_scaled_down_to_the_largest_allowed():
    step = limited_step(np.eye(1)[None], np.array([[2.0]]), np.zeros((1, 1)), -9, 9, np.zeros(1))
    assert step[0, 0] == pytest.approx(0.3)


def test_the_pitch_target_keeps_the_axis_heading_at_the_asked_elevation():
    axis = np.array([[0.0, 1.0, 0.0]])  # level, heading +y
    pitch = np.radians(30.0)
    target, _ = axis_with_pitch(axis, np.zeros((1, 3)), np.array([[np.cos(pitch), np.sin(pitch)]]))
    assert np.allclose(target, [[0.0, np.cos(pitch), np.sin(pitch)]])


def test_attempts_reach_within_the_tolerances_and_cost_mm_and_degrees_alike():
    attempts = Attempts(np.zeros((2, 1)), np.array([[0.4], [0.6]]), np.array([[0.1], [0.0]]))
    assert attempts.reached.tolist() == [True, False]
    assert attempts.cost.tolist() == pytest.approx([0.5, 0.6])


def test_a_descent_reaches_a_site_that_moves_one_metre_per_radian():
    """One site moved along x by joint 0 only (x = q0 metres): a 0.2 m target is reached at
    q0 = 0.2 rad, and the joint no goal moves stays as given."""
    task = Task(
        sites=np.array([0]),
        moves=np.array([[True, False]]),
        targets=np.array([[0.2, 0.0, 0.0]]),
        pitched=np.array([False]),
        pitch_deg=np.zeros(0),
        pitch_cos_sin=np.zeros((0, 2)),
    )

    def poses(task: Task, q_rad: np.ndarray) -> Poses:
        n = len(q_rad)
        positions = np.zeros((n, 1, 3))
        positions[:, 0, 0] = q_rad[:, 0]
        jac = np.zeros((n, 1, 3, 2))
        jac[:, 0, 0, 0] = 1.0
        return Poses(positions, np.zeros((n, 1, 3)), jac, np.zeros((n, 1, 3, 2)))

    limits = (np.array([-90.0, -90.0]), np.array([90.0, 90.0]))
    start = np.array([[0.0, 12.5]])
    attempts = descend(task, start, np.array([True, False]), 50, limits, poses)
    assert attempts.reached.tolist() == [True]
    assert attempts.angles_deg[0, 0] == pytest.approx(np.degrees(0.2), abs=1e-3)
    assert attempts.angles_deg[0, 1] == 12.5
