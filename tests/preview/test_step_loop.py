"""The simulation's step loop: a rollout resumed from a checkpoint is the fresh one, bit for bit;
one whose ticks end as an earlier run's takes that run's rest once its state is that run's,
and equals the full run within the tolerance (findings and contacts too), but a change whose
effect lasts is simulated to the end; where each START begins; a simulation that blows up is an
error."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
from preview_helpers import DATA, linear_ticks

from choreo.errors import PreviewError
from choreo.plan.ticks import Tick
from choreo.preview import (
    MoveStart,
    SimSettings,
    run_checks,
    simulate,
)
from choreo.preview.step_loop import CHECKPOINT_S, JOIN_TOLERANCE
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
    # the physics ran on from the last checkpoint before 1.5 s: those before it are reused
    dt = float(fresh.times_s[1] - fresh.times_s[0])
    restored_s = np.ceil(1.5 / CHECKPOINT_S - 1) * CHECKPOINT_S
    checkpoints = resumed.resume.checkpoints
    reused = [c for c in checkpoints if any(c is b for b in before.resume.checkpoints)]
    assert [c.step * dt for c in reused] == pytest.approx(np.arange(0, restored_s, CHECKPOINT_S))
    assert checkpoints[len(reused)].step * dt == pytest.approx(restored_s)


def shifted(ticks: list[Tick], ms: int) -> list[Tick]:
    return [dataclasses.replace(t, start_ms=t.start_ms + ms) for t in ticks]


def reused_steps(rollout, before) -> list[int]:
    """The checkpoints ``rollout`` took from ``before``'s run rather than simulating them."""
    theirs = {id(c.servos) for c in before.resume.checkpoints}
    return [c.step for c in rollout.resume.checkpoints if id(c.servos) in theirs]


def without_values(findings):
    return [dataclasses.replace(f, value=None) for f in findings]


def test_a_run_that_ends_as_an_earlier_one_takes_its_rest_and_equals_the_full_run(arm3):
    home, fold, floor = np.zeros(3), np.array([0.0, 70.0, 110.0]), np.array([0.0, 100.0, 60.0])
    # from 2 s the same: down onto the floor and held there
    rest = shifted(linear_ticks(arm3, home, floor, 2000, 100), 2000)
    rest += shifted(linear_ticks(arm3, floor, floor, 1500, 500), 4000)
    before = simulate(arm3, linear_ticks(arm3, home, home, 2000, 500) + rest, home)
    # first folded into the base plate and back: a touch the earlier run never had
    changed = linear_ticks(arm3, home, fold, 1000, 100)
    changed += shifted(linear_ticks(arm3, fold, home, 1000, 100), 1000) + rest
    full = simulate(arm3, changed, home)
    spliced = simulate(arm3, changed, home, resume=before.resume)

    dt = float(full.times_s[1] - full.times_s[0])
    reused = reused_steps(spliced, before)
    assert reused and 2.0 < reused[0] * dt < 4.0  # rejoined after 2 s, before the floor
    assert reused == [c.step for c in before.resume.checkpoints if c.step >= reused[0]]
    assert np.abs(spliced.qpos - full.qpos).max() <= JOIN_TOLERANCE
    assert np.abs(spliced.position_deg - full.position_deg).max() <= np.degrees(JOIN_TOLERANCE)
    assert np.abs(spliced.torque_nm - full.torque_nm).max() < 1e-6
    assert np.array_equal(spliced.setpoint_deg, full.setpoint_deg)
    # the floor touches come from the earlier run, its pair numbered after the new one's
    assert [p.kind for p in spliced.contacts.pairs] == ["self", "floor"]
    assert spliced.contacts.pairs == full.contacts.pairs
    assert np.array_equal(spliced.contacts.step, full.contacts.step)
    assert np.array_equal(spliced.contacts.pair, full.contacts.pair)
    assert spliced.contacts.depth_m == pytest.approx(full.contacts.depth_m, abs=1e-9)
    findings = run_checks(spliced)
    assert without_values(findings) == without_values(run_checks(full))
    assert {f.kind.value for f in findings} >= {"self_collision", "floor_contact"}
    # a later change resumes from a checkpoint the spliced run took (its contacts counted right)
    lifted = changed[:-1] + shifted(linear_ticks(arm3, floor, home, 1000, 100), 5000)
    again = simulate(arm3, lifted, home, resume=spliced.resume)
    restored_s = np.ceil(5.0 / CHECKPOINT_S - 1) * CHECKPOINT_S  # the last before 5 s
    assert max(reused_steps(again, before)) * dt == pytest.approx(restored_s - CHECKPOINT_S)
    full_again = simulate(arm3, lifted, home)
    assert np.abs(again.qpos - full_again.qpos).max() <= JOIN_TOLERANCE
    assert again.contacts.pairs == full_again.contacts.pairs
    assert np.array_equal(again.contacts.step, full_again.contacts.step)


def test_a_walker_that_slid_on_the_floor_takes_the_earlier_run_shifted_as_far(hexapod):
    """Nothing in the world tells one place on the floor from another: a body that went on
    as before a few millimetres over goes on so to the end."""
    home = np.array(hexapod.pose_vector("home"))
    lower = np.array([j.limits.min_deg for j in hexapod.joints])
    upper = np.array([j.limits.max_deg for j in hexapod.joints])

    def crouch_then_sway(depth_deg: float) -> list[Tick]:
        crouch = np.clip(home + depth_deg, lower, upper)
        sway = np.clip(home + np.tile([6.0, 0.0, 0.0], 6), lower, upper)
        ticks = linear_ticks(hexapod, home, crouch, 1000, 100)
        ticks += shifted(linear_ticks(hexapod, crouch, home, 1000, 100), 1000)
        ticks += shifted(linear_ticks(hexapod, home, sway, 1000, 100), 2000)
        ticks += shifted(linear_ticks(hexapod, sway, home, 1000, 100), 3000)
        return ticks + shifted(linear_ticks(hexapod, home, home, 2000, 500), 4000)

    before = simulate(hexapod, crouch_then_sway(8.0), home)
    changed = crouch_then_sway(12.0)
    full = simulate(hexapod, changed, home)
    spliced = simulate(hexapod, changed, home, resume=before.resume)
    assert reused_steps(spliced, before)  # the rest taken
    root = full.body.qpos_address
    slid = np.abs(before.qpos[-1, root : root + 2] - full.qpos[-1, root : root + 2]).max()
    assert slid > 5 * JOIN_TOLERANCE  # the deeper crouch left the body elsewhere
    assert np.abs(spliced.qpos - full.qpos).max() <= JOIN_TOLERANCE
    assert np.array_equal(spliced.contacts.step, full.contacts.step)


def test_a_change_whose_effect_lasts_is_simulated_to_the_end_not_spliced_away():
    """The same ticks after the first, but the first stages the shoulder under the payload
    higher: every later START re-runs that preset, and the shoulder stalls to the end."""
    heavy = load_robot(DATA / "models" / "arm3_heavy" / "robot.yaml")

    def units(angles_deg) -> tuple[int, ...]:
        return tuple(round(j.to_units(a)) for j, a in zip(heavy.joints, angles_deg))

    def yaw_swing(shoulder_deg: float) -> list[Tick]:
        ticks = [Tick(0, 1000, units([0, shoulder_deg, 0]), (True,) * 3)]
        for k in range(1, 10):  # the yaw alone staged: the others re-run their presets
            ticks.append(
                Tick(500 + 500 * k, 500, units([20 * (-1) ** k, 0, 0]), (True, False, False))
            )
        return ticks

    home = np.zeros(3)
    before = simulate(heavy, yaw_swing(0), home)
    changed = yaw_swing(90)
    full = simulate(heavy, changed, home)
    spliced = simulate(heavy, changed, home, resume=before.resume)
    assert reused_steps(spliced, before) == []
    assert np.array_equal(spliced.qpos, full.qpos)
    stalls = [f for f in run_checks(spliced) if f.kind.value == "saturation"]
    assert stalls and stalls[-1].time_s + stalls[-1].duration_s == pytest.approx(
        full.duration_s, abs=0.05
    )
    assert not [f for f in run_checks(before) if f.kind.value == "saturation"]


def test_a_model_edited_on_disk_is_simulated_afresh(tmp_path, arm3):
    """The robot file is as it was, so the robot compares equal: the model's digest tells."""
    shutil.copytree(arm3.path.parent, tmp_path / "arm3")
    ticks = linear_ticks(arm3, [0, 0, 0], [0, 60, 0], 2000, 100)
    robot = load_robot(tmp_path / "arm3" / "robot.yaml")
    before = simulate(robot, ticks, [0, 0, 0])
    mjcf = tmp_path / "arm3" / "arm3.xml"
    heavier = mjcf.read_text().replace('pos="0 0 0.07" mass="0.05"', 'pos="0 0 0.07" mass="0.5"')
    assert heavier != mjcf.read_text()
    mjcf.write_text(heavier)
    robot = load_robot(tmp_path / "arm3" / "robot.yaml")
    fresh = simulate(robot, ticks, [0, 0, 0])
    resumed = simulate(robot, ticks, [0, 0, 0], resume=before.resume)
    assert np.array_equal(resumed.qpos, fresh.qpos)
    assert not np.allclose(fresh.qpos, before.qpos, atol=1e-3)  # the heavier forearm sags


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
