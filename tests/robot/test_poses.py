"""A robot file's named poses: each naming every joint, inside its limits, home among them."""

from __future__ import annotations

from robot_helpers import BAD, only_problem, problems_of


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
