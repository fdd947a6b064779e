"""The simulation's step loop: a rollout resumed from a checkpoint is the fresh one, bit for bit;
where each START begins; a simulation that blows up is an error."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from preview_helpers import DATA, linear_ticks

from choreo.errors import PreviewError
from choreo.plan.ticks import Tick
from choreo.preview import (
    MoveStart,
    SimSettings,
    simulate,
)
from choreo.robot.robot_file import load_robot


def test_a_resumed_rollout_is_the_fresh_one_and_reuses_what_came_before_the_change(hexapod):
    home = np.array(hexapod.pose_vector("home"))
    lower = np.array([j.limits.min_deg for j in hexapod.joints])
    upper = np.array([j.limits.max_deg for j in hexapod.joints])
    crouch = np.clip(home + 8.0, lower, upper)
    first = linear_ticks(hexapod, home, crouch, 2400, 100)
    # the same ticks until 1.5 s, then back home instead of on down
    midway = home + (crouch - home) * 15 / 24
    back = linear_ticks(hexapod, midway, home, 900, 100)
    changed = first[:15] + [dataclasses.replace(t, start_ms=1500 + t.start_ms) for t in back]
    before = simulate(hexapod, first, home)
    fresh = simulate(hexapod, changed, home)
    resumed = simulate(hexapod, changed, home, resume=before.resume)

    def assert_same(ours, theirs, name):
        if isinstance(ours, np.ndarray):
            assert np.array_equal(ours, theirs), name
        elif dataclasses.is_dataclass(ours) and name in ("contacts", "body"):
            for field in dataclasses.fields(ours):
                assert_same(getattr(ours, field.name), getattr(theirs, field.name), field.name)
        else:
            assert ours == theirs, name

    for field in dataclasses.fields(fresh):
        if field.name != "resume":
            assert_same(getattr(fresh, field.name), getattr(resumed, field.name), field.name)
    assert len(fresh.contacts.step) > 0  # the feet on the floor: the contact log resumed too
    # the physics ran on from the last checkpoint before 1.5 s (1 s): those before it are reused
    dt = float(fresh.times_s[1] - fresh.times_s[0])
    checkpoints = resumed.resume.checkpoints
    reused = [c for c in checkpoints if any(c is b for b in before.resume.checkpoints)]
    assert [c.step * dt for c in reused] == [0.0]
    assert checkpoints[len(reused)].step * dt == pytest.approx(1.0)


def test_moves_from_the_measured_position_make_a_loaded_joint_sag_more(arm3):
    """The pessimistic assumption: each START forgets the lag."""
    heavy = load_robot(DATA / "models" / "arm3_heavy" / "robot.yaml")
    ticks = linear_ticks(heavy, [0, 20, 0], [0, 20, 0], 1000, 50)
    errors = {}
    for start in MoveStart:
        rollout = simulate(heavy, ticks, [0, 20, 0], settings=SimSettings(move_start=start))
        errors[start] = np.abs(rollout.position_deg[:, 1] - 20).max()
    assert errors[MoveStart.SETPOINT] < 6  # static sag: torque / kp
    assert errors[MoveStart.POSITION] > errors[MoveStart.SETPOINT] + 1


def test_a_simulation_that_blows_up_is_an_error_naming_the_joint(arm3):
    absurd = {
        "kp_nm_rad": 1e9,
        "stall_torque_nm": 1e9,
        "armature_kg_m2": 1e-9,
        "damping_nm_s_rad": 1e-9,
    }
    settings = SimSettings(actuator_overrides={"shoulder": absurd})
    ticks = [Tick(0, 0, (500, 900, 500), (True,) * 3)]
    with pytest.raises(PreviewError, match="unstable .*last at shoulder"):
        simulate(arm3, ticks, [0, 0, 0], settings=settings)
