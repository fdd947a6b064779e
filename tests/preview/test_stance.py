"""The preview judging what happens over time and in space: strain repeated in short pushes,
stumbles against the planned body pose, declared endings, and a walker's stance from raw
keyframes (feet a keyframe raises are lifted, not a tilt; a body rocked by its legs is)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from paths import DATA, REPO

from choreo.errors import SourceError
from choreo.motion.motion_file import load_motion
from choreo.preview import CheckKind, CheckThresholds, Severity, run_checks, simulate_motion
from choreo.preview.stance import floors_kept
from choreo.robot.kinematics import Kinematics
from choreo.robot.robot_file import load_robot

TONYPI = REPO / "motions" / "tonypi"
MOTIONS = DATA / "preview" / "motions"


def repeated(tmp_path: Path, motion: Path, times: int) -> Path:
    path = tmp_path / f"{motion.stem}_x{times}.yaml"
    path.write_text(f"robot: tonypi\nrepeat: {times}\nkeyframes:\n  - include: {motion}\n")
    return path


def test_short_pushes_at_the_torque_limit_repeated_are_a_near_miss(tmp_path):
    """left_move_fast shifts the weight onto the right leg in 0.13 s: the right hip roll servo
    reaches 100 % of its stall torque for a few tens of ms, 0.07 s in all, less than the 0.1 s a
    near miss needs. Played 6 times, the same pushes come one after another, adding up to
    0.15 s within a second: a (repeated) near miss. Once, it still passes."""
    once = run_checks(simulate_motion(load_motion(TONYPI / "left_move_fast.yaml")))
    assert once == []
    simulated = simulate_motion(load_motion(repeated(tmp_path, TONYPI / "left_move_fast.yaml", 6)))
    (near,) = run_checks(simulated)
    assert near.kind is CheckKind.NEAR_MISS and near.severity is Severity.WARNING
    assert near.joint == "right_hip_roll" and "repeated near miss" in near.message
    assert near.value >= 98  # it reaches the limit
    # a 0.2 s window holds too little of it to count
    narrow = CheckThresholds(near_miss_window_s=0.2)
    assert run_checks(simulated, narrow) == []


def test_a_declared_lie_down_passes_and_the_same_motion_undeclared_is_a_fall():
    """stand_up backwards: the torso is lowered onto the floor from crouch. Without ``end:`` the
    body drops to half its height and touches the floor: falls. With ``end: lying`` it is what
    the motion means to do from its last keyframe but one on."""
    undeclared = run_checks(simulate_motion(load_motion(MOTIONS / "lie_down.yaml")))
    assert {r.kind for r in undeclared} == {CheckKind.FALL}
    declared = simulate_motion(load_motion(MOTIONS / "lie_down_declared.yaml"))
    assert run_checks(declared) == []
    lying_from = declared.lie_down_from_s
    assert lying_from == declared.rollout.keyframe_times_s[1]  # from crouch on
    assert all(r.time_s >= lying_from for r in undeclared)


def test_end_is_read_like_start_and_refused_in_an_included_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("robot: hexapod18\nend: sitting\nkeyframes:\n  - pose: home\n")
    with pytest.raises(SourceError, match=r"bad.yaml:2:6: .*end.*lying_front"):
        load_motion(bad)
    inner = tmp_path / "inner.yaml"
    inner.write_text("end: lying\nkeyframes:\n  - pose: home\n")
    outer = tmp_path / "outer.yaml"
    outer.write_text("robot: hexapod18\nkeyframes:\n  - include: inner.yaml\n")
    with pytest.raises(SourceError, match=r"end is not allowed in an included file"):
        load_motion(outer)


def test_a_stumble_onto_lifted_legs_is_judged_against_the_plan():
    """four_legs_up.yaml leaves the hexapod on its two middle feet: it pitches over them and its
    body comes down ~7 mm onto two of the lifted legs. The old rules miss it (no link but the
    tibias touches the floor, a few degrees of tilt, far from half its height); against the
    plan, the body is lower than planned and two feet the plan holds 15 mm up are on the floor."""
    simulated = simulate_motion(load_motion(MOTIONS / "four_legs_up.yaml"))
    results = run_checks(simulated)
    assert {(r.kind, r.severity) for r in results} == {(CheckKind.FALL, Severity.ERROR)}
    lower = [r for r in results if "lower than its plan" in r.message]
    assert len(lower) == 1 and lower[0].value > 5
    corners = ("lf_tibia", "lr_tibia", "rf_tibia", "rr_tibia")
    down = [r.bodies[0] for r in results if "lifted leg" in r.message]
    assert len(down) == 2 and set(down) <= set(corners)
    # the plan: the four corner feet 15 mm up, the two middle ones on the floor
    stance = simulated.walk.stance
    lifts = 1000 * stance.lift_m[np.searchsorted(simulated.rollout.times_s, 1.0)]
    planned = dict(zip(stance.foot_links, lifts))
    assert planned["lm_tibia"] < 1 and planned["rm_tibia"] < 1
    assert all(abs(planned[foot] - 15) < 1 for foot in corners)


# --- a walker's stance from raw keyframes: raised feet are lifted, a rocked body is a tilt ------
HEXAPOD = load_robot(REPO / "models" / "hexapod18" / "robot.yaml")
# the dance's rock: the left legs bent more than the right, all six feet on the floor
LEFT_LOW = {"femur": (37, 24), "tibia": (-18, -11)}


def rocked(robot) -> tuple[float, ...]:
    pose = dict(robot.poses["home"])
    for side, index in (("l", 0), ("r", 1)):
        for leg in "fmr":
            for part, angles in LEFT_LOW.items():
                pose[f"{side}{leg}_{part}"] = angles[index]
    return tuple(pose[name] for name in robot.joint_names)


def test_a_keyframe_raising_four_feet_keeps_the_floor_a_rocked_body_tilts_it():
    front_up = load_motion(MOTIONS / "front_legs_up.yaml").keyframes[1].targets_deg
    home = HEXAPOD.pose_vector("home")
    kin = Kinematics(HEXAPOD)
    kept = floors_kept(kin, [home, front_up, home], [False] * 3)
    assert kept[0] is None  # the start: fitted
    assert np.allclose(kept[1], [0, 0, 1])  # four raised: the level floor kept, they are lifted
    assert np.allclose(kept[2], [0, 0, 1])  # two feet were down: no plane to tilt on
    assert floors_kept(kin, [home, rocked(HEXAPOD), home], [False] * 3) == [None] * 3
    # the same four feet raised by a body: keyframe would be a tilt the plan means
    assert floors_kept(kin, [home, front_up], [False, True]) == [None, None]


def test_a_hexapod_lifting_its_front_and_middle_legs_tips_onto_them_and_is_reported():
    """Written as sites: (no gait, no body: keyframe): the rear two feet are all it leaves
    down; it tips forward onto the raised legs (before: read as a tilt, nothing reported)."""
    path = MOTIONS / "front_legs_up.yaml"
    results = run_checks(simulate_motion(path))
    assert results and all(r.severity is Severity.ERROR for r in results)
    assert {r.kind for r in results} == {CheckKind.FALL}
    onto = [r for r in results if "while the plan has its foot" in r.message]
    # the front pair always lands on its raised feet; whether the middle pair touches too
    # depends on the servos' figures (the twin's actuator lets the body pitch less)
    raised = {"lf_tibia", "rf_tibia", "lm_tibia", "rm_tibia"}
    assert {"lf_tibia", "rf_tibia"} <= {r.bodies[0] for r in onto} <= raised
    assert max(r.value for r in onto) >= 14  # the 15 mm the keyframe raises them
    assert any("lower than its plan puts it" in r.message for r in results)
