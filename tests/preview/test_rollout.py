"""What a simulation records: a free-floating robot's body, the contacts per step, the phases and
the rollout from its start."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from preview_helpers import linear_ticks

from choreo.preview import run_checks, simulate
from choreo.preview.rollout import ContactPair, Contacts


def test_a_free_floating_robot_starts_standing_on_its_home_keyframe(hexapod):
    home = hexapod.pose_vector("home")
    rollout = simulate(hexapod, linear_ticks(hexapod, home, home, 300, 100), home)
    model = mujoco.MjModel.from_xml_path(str(hexapod.mjcf_path))
    key_height = model.key("home").qpos[2]
    assert rollout.body.name == "torso"
    assert rollout.body.height_m[rollout.start_step] == pytest.approx(key_height, abs=0.005)
    assert rollout.body.tilt_deg.max() < 1.0
    assert run_checks(rollout) == []


def contacts_of(steps, pairs, depths_m) -> Contacts:
    names = (ContactPair("self", "base", "forearm"), ContactPair("floor", "hand", "floor"))
    return Contacts(names, np.array(steps), np.array(pairs), np.array(depths_m))


def test_a_pairs_contacts_are_masked_per_step_keeping_the_deepest_touch():
    contacts = contacts_of([1, 1, 3, 3], [0, 0, 0, 1], [0.001, 0.004, 0.002, 0.009])
    touching, depth = contacts.mask(0, 5)
    assert touching.tolist() == [False, True, False, True, False]
    assert depth.tolist() == [0.0, 0.004, 0.0, 0.002, 0.0]


def test_contacts_since_a_step_count_their_steps_from_there():
    later = contacts_of([1, 2, 4], [0, 1, 0], [0.001, 0.002, 0.003]).since(2)
    assert (later.step.tolist(), later.pair.tolist(), later.depth_m.tolist()) == (
        [0, 2],
        [1, 0],
        [0.002, 0.003],
    )


def test_the_rollout_from_its_start_drops_the_settling_and_names_each_phase(arm3):
    rollout = simulate(arm3, [], [10, 20, 30], motion_start_s=0.1)
    assert rollout.approach_start_s == -0.1
    assert rollout.times_s[0] < -0.1  # the settling came first
    judged = rollout.since_start()
    assert judged.times_s[0] == rollout.times_s[rollout.start_step]
    assert (
        len(judged.position_deg) == len(judged.times_s) == len(rollout.times_s) - rollout.start_step
    )
    assert judged.start_step == 0
    assert [rollout.phase(t) for t in (rollout.times_s[0], -0.05, 0.0)] == [
        "settling",
        "approach",
        "motion",
    ]
