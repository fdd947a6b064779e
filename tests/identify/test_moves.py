"""Each joint's test moves: inside its limits, with what each part is for."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.identify.fit import READ_HALF_UNIT_DEG, assumed_figures, read_miss_deg
from choreo.identify.joint_model import SentMove, Trial, Unload, figures_of, simulate
from choreo.identify.moves import (
    LOADED_REACH_DEG,
    LOADED_SHARE,
    MARGIN_DEG,
    fit_moves,
    held_out_moves,
    loaded_poses,
)
from choreo.preview.actuator import actuator_params
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")


@pytest.mark.parametrize("name, pose", [("elbow", 0.0), ("gripper", 0.0), ("shoulder", 88.0)])
def test_every_move_stays_inside_the_limits_with_a_margin(name, pose):
    joint = ARM6.joint(name)
    for moves in (fit_moves(joint, pose, drop=True), held_out_moves(joint, pose)):
        targets = [c.target_deg for c in moves.commands if isinstance(c, SentMove)]
        assert min(targets) >= joint.limits.min_deg + MARGIN_DEG - 1e-9
        assert max(targets) <= joint.limits.max_deg - MARGIN_DEG + 1e-9
        times = [c.at_s for c in moves.commands]
        assert times == sorted(times) and moves.duration_s > times[-1]


def test_the_fit_moves_have_slow_triangles_small_reversals_steps_and_holds():
    moves = fit_moves(ARM6.joint("elbow"), 0.0)
    sent = [c for c in moves.commands if isinstance(c, SentMove)]
    speeds = {
        round(abs(b.target_deg - a.target_deg) / b.time_s)
        for a, b in zip(sent, sent[1:])
        if b.time_s >= 0.5
    }
    assert 10 in speeds  # a slow triangle
    sizes = {round(abs(b.target_deg - a.target_deg), 2) for a, b in zip(sent, sent[1:])}
    assert {0.5, 1.0, 2.0} <= sizes  # small reversals
    assert {0.0, 0.15, 0.4} <= {c.time_s for c in sent}  # steps at several move times
    assert not any(isinstance(c, Unload) for c in moves.commands)  # no drop unless asked


def test_a_drop_only_when_asked():
    moves = fit_moves(ARM6.joint("elbow"), 0.0, drop=True)
    assert sum(isinstance(c, Unload) for c in moves.commands) == 1


def test_a_joint_whose_tests_carry_too_little_gravity_gets_loaded_triangles_inside_its_limits():
    pose = [0.0] * len(ARM6.joints)  # the arm upright: the light wrist carries 0.03 N·m at ±20°
    stall = dict(zip(ARM6.joint_names, (p.stall_torque_nm for p in actuator_params(ARM6))))
    wrist = ARM6.joint("wrist_pitch")
    load = joint_load(ARM6, "wrist_pitch", pose)
    poses = loaded_poses(wrist, 0.0, load, stall["wrist_pitch"])
    assert len(poses) == 2 and poses[0] > 0 > poses[1]  # either side, the nearer one first
    for at in poses:
        assert abs(load.gravity_at(np.radians(at))) >= LOADED_SHARE * stall["wrist_pitch"]
        assert abs(at) <= LOADED_REACH_DEG
    moves = fit_moves(wrist, 0.0, loaded=poses)
    targets = [c.target_deg for c in moves.commands if isinstance(c, SentMove)]
    assert min(targets) >= wrist.limits.min_deg + MARGIN_DEG
    assert max(targets) <= wrist.limits.max_deg - MARGIN_DEG
    for at in poses:  # a slow triangle around each, then back
        assert any(abs(t - at) < 4 for t in targets)
    assert moves.duration_s > fit_moves(wrist, 0.0).duration_s
    # the elbow's own tests reach 0.1 N·m; gravity never loads the base's upright axis
    for name in ("elbow", "base_yaw"):
        load = joint_load(ARM6, name, pose)
        assert loaded_poses(ARM6.joint(name), 0.0, load, stall[name]) == ()


# ~3 s of CPU (2026-11-27, a loaded machine): one trial each way at the reference 1 ms step,
# three candidates on each
def test_loaded_triangles_tell_friction_from_dead_band_where_the_usual_moves_cannot():
    """Along the line where the dead band plus twice the friction over the gain stays the same
    (all the usual moves show of a light wrist), the truth costs more than a friction 25 % low
    on the joint model's own whole-unit reads; with the loaded triangles it costs clearly less
    than either end of the line."""
    j = ARM6.joint_names.index("wrist_pitch")
    load = joint_load(ARM6, "wrist_pitch", [0.0] * len(ARM6.joints))
    params = actuator_params(ARM6)[j]
    truth = {
        **assumed_figures(params),
        "friction_nm": 0.04,
        "deadband_deg": 0.23,
        "backlash_deg": 1.4,
        "response_delay_s": 0.018,
        "kp_nm_rad": 16.6,
    }

    def along_the_line(scale: float) -> dict[str, float]:
        more_nm = truth["friction_nm"] * (scale - 1)
        less_deg = np.degrees(2 * more_nm / truth["kp_nm_rad"])
        return {
            **truth,
            "friction_nm": truth["friction_nm"] * scale,
            "deadband_deg": truth["deadband_deg"] - less_deg,
        }

    def costs(loaded: tuple[float, ...]) -> np.ndarray:
        plan = fit_moves(ARM6.joints[j], 0.0, loaded=loaded)
        read_s = np.arange(0.0, plan.duration_s, 0.0037)
        unread = Trial(plan.commands, read_s, np.zeros(len(read_s)), 0.0)
        moved_deg = simulate(unread, load, figures_of([truth]), dt_s=0.001)[:, 0]
        unit = 2 * READ_HALF_UNIT_DEG
        trial = Trial(plan.commands, read_s, np.round(moved_deg / unit) * unit, 0.0)
        candidates = figures_of([truth, along_the_line(0.75), along_the_line(1.25)])
        return read_miss_deg(trial, simulate(trial, load, candidates))

    usual = costs(())
    assert usual[1] < usual[0]  # the usual moves take a friction 25 % low for the truth
    loaded = costs(loaded_poses(ARM6.joints[j], 0.0, load, params.stall_torque_nm))
    assert loaded[1] > 2 * loaded[0] and loaded[2] > 1.3 * loaded[0]
