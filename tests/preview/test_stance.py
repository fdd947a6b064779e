"""A walker's planned stance from raw keyframes: feet a ``pose:`` or ``sites:`` keyframe raises
are lifted, not read as a tilt that keeps them on the floor; a body rocked by its legs, all
feet down, is a tilt."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from choreo.motion.motion_file import load_motion
from choreo.preview import CheckKind, Severity, run_checks, simulate_motion
from choreo.preview.stance import floors_kept
from choreo.robot.kinematics import Kinematics
from choreo.robot.robot_file import load_robot

REPO = Path(__file__).resolve().parents[2]
MOTIONS = REPO / "tests" / "data" / "preview" / "motions"
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
    assert {r.bodies[0] for r in onto} == {"lf_tibia", "rf_tibia", "lm_tibia", "rm_tibia"}
    assert max(r.value for r in onto) >= 14  # the 15 mm the keyframe raises them
    assert any("lower than its plan puts it" in r.message for r in results)
