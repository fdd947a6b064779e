"""One joint's load with the rest of the robot held: inertia and gravity over its range."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.preview.actuator import actuator_params
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")


def test_gravity_on_the_shoulder_is_nothing_upright_and_most_leaning_out():
    load = joint_load(ARM6, "shoulder", [0.0] * 6)
    upright, forward, back = (float(load.gravity_at(np.radians([a]))[0]) for a in (0, 80, -80))
    assert abs(upright) < 0.02
    assert forward > 0.2 and back < -0.2  # pulls further the way it leans
    assert forward == pytest.approx(-back, rel=0.1)


def test_the_base_turning_carries_no_gravity_and_the_inertia_includes_the_armature():
    load = joint_load(ARM6, "base_yaw", [0.0] * 6)
    assert np.abs(load.gravity_nm).max() < 1e-6
    assert np.all(load.inertia_kg_m2 > 0.005)  # the servo's armature and more
    assert load.angles_deg[0] == ARM6.joint("base_yaw").limits.min_deg


def test_the_elbows_neighbours_are_the_joints_next_to_it_on_parallel_axes():
    load = joint_load(ARM6, "elbow", [0.0] * 6)
    assert [c.joint for c in load.neighbours] == ["shoulder", "wrist_pitch"]
    shoulder, wrist = load.neighbours
    # the shoulder accelerating carries the whole forearm with it: a coupling near the
    # elbow's own inertia; the hand beyond the wrist is lighter
    upright = int(np.searchsorted(load.angles_deg, 0.0))
    assert 0.5 < shoulder.inertia_kg_m2[upright] / load.inertia_kg_m2[upright] < 1.0
    assert 0 < wrist.inertia_kg_m2[upright] < shoulder.inertia_kg_m2[upright]
    # on parallel axes, gravity on the forearm goes with the shoulder's angle plus the elbow's:
    # turning the shoulder changes it as turning the elbow does
    own_slope = np.gradient(load.gravity_nm, np.radians(load.angles_deg))
    assert shoulder.gravity_nm_rad[upright] == pytest.approx(own_slope[upright], rel=0.05)


def test_a_neighbour_on_a_crossed_axis_is_not_one():
    # the shoulder pitches, the base turns about the vertical: neither pushes on the other
    assert joint_load(ARM6, "base_yaw", [0.0] * 6).neighbours == ()
    assert [c.joint for c in joint_load(ARM6, "shoulder", [0.0] * 6).neighbours] == ["elbow"]


def test_a_neighbour_carries_its_own_neighbours_on_parallel_axes():
    """The shoulder's elbow swings the wrist_pitch with it (not read: the shoulder's
    neighbours are read, not theirs); the elbow's neighbours carry nothing more in pitch."""
    shoulder = joint_load(ARM6, "shoulder", [0.0] * 6)
    assert [c.joint for c in shoulder.carried] == ["wrist_pitch"]
    assert shoulder.neighbour_inertia_kg_m2.shape[1:] == (2, 2)
    assert joint_load(ARM6, "elbow", [0.0] * 6).carried == ()


def test_the_neighbours_as_joints_of_their_own_their_mass_matrix_gravity_and_servos():
    load = joint_load(ARM6, "elbow", [0.0] * 6)
    upright = int(np.searchsorted(load.angles_deg, 0.0))
    mass = load.neighbour_inertia_kg_m2[upright]
    slopes = load.neighbour_gravity_nm_rad[upright]
    shoulder, wrist = load.neighbours
    # the shoulder carries the whole arm, the wrist_pitch only the hand; both more than the
    # armature of their servos, which holds them at the robot file's figures
    assert mass[0, 0] > mass[1, 1] > shoulder.servo.armature_kg_m2
    assert mass[0, 1] == pytest.approx(mass[1, 0]) and 0 < mass[0, 1] < mass[1, 1]
    # gravity's slopes are a potential's second derivatives: symmetric, the wrist's on the
    # shoulder as the shoulder's on the wrist
    assert slopes[0, 1] == pytest.approx(slopes[1, 0], rel=0.02)
    assert abs(shoulder.held_gravity_nm[upright]) < 0.02  # upright: nothing to hold
    bent = int(np.searchsorted(load.angles_deg, 60.0))
    assert shoulder.held_gravity_nm[bent] > 0.1  # the forearm leaning out pulls the shoulder on
    assert shoulder.servo == actuator_params(ARM6)[1]
