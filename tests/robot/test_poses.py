"""A robot file's named poses: each naming every joint, inside its limits, home among them."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from paths import REPO
from robot_helpers import BAD, only_problem, problems_of

from choreo.core.yaml_source import Problems, Reader
from choreo.robot import poses
from choreo.robot.poses import read_angles
from choreo.robot.robot_file import load_robot


def test_missing_home_pose():
    path, message = only_problem("missing_home")
    assert message.startswith(
        f"{path}:11:1: poses: the 'home' pose is missing (did you mean 'hom'?); it is required"
    )


def test_pose_problems_each_reported():
    path = BAD / "pose_problems" / "robot.yaml"
    assert problems_of(path) == [
        f"{path}:13:3: pose 'reach' does not give right; every pose names every joint",
        f"{path}:14:16: pose 'twist': yaw 100° is outside its limits -90..90°",
        f"{path}:15:3: pose 'shrug' does not give left; every pose names every joint",
        f"{path}:15:19: pose 'shrug': unknown joint 'lft' (did you mean 'left'?); the robot's "
        f"joints are yaw, left, right",
    ]


# Pose mappings read_angles takes in one quick pass (the first two) or reads in full, reporting.
POSE_MAPPINGS = [
    "{shoulder: 30, elbow: -12.5}",
    "{shoulder: 0, elbow: +5, gripper: -0.0}",
    "{shoulder: 30, shoulder: 40}",
    "{shoulder: 1000}",
    "{sholder: 30}",
    "{shoulder: .nan, elbow: 0x1F}",
    "{shoulder: '30'}",
    "{[shoulder]: 30}",
    "{!!str [1]: 30}",
    "{shoulder: !!float [1]}",
    "[30]",
]


@pytest.mark.parametrize("text", POSE_MAPPINGS)
def test_the_quick_pass_reads_a_pose_as_the_full_reading_does(text, monkeypatch):
    robot = load_robot(REPO / "models" / "arm6" / "robot.yaml")
    joints = {joint.name: joint for joint in robot.joints}

    def read(quick: bool) -> tuple[object, list[str]]:
        if not quick:
            monkeypatch.setattr(poses, "_plain_angles", lambda node, joints: None)
        problems = Problems()
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        return read_angles(
            Reader(Path("m.yaml"), problems), node, "pose", joints
        ), problems.messages

    quick = read(quick=True)
    assert quick == read(quick=False)
    assert (quick[1] == []) == (text in POSE_MAPPINGS[:2])
