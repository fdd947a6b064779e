"""One keyframe as written: its options, its pose (a name or joint angles), its one timing, each
mistake at its line with what would be valid."""

from __future__ import annotations

import warnings

import pytest
from cli_helpers import error_line, motion_file
from motion_helpers import GOOD, only_problem, problems_of

from choreo.cli import main
from choreo.motion.motion_file import load_motion


def test_keyframe_options():
    third = load_motion(GOOD / "wave.yaml").keyframes[2]
    assert (third.t_s, third.hold_s, third.velocity_scale) == (2.0, 0.25, 0.5)
    assert third.stop is True  # a hold implies stop
    assert third.where.path == GOOD / "wave.yaml" and third.where.line == 11


def test_unknown_joint_with_did_you_mean():
    path, message = only_problem("unknown_joint.yaml")
    assert message == (
        f"{path}:4:21: pose: unknown joint 'lefft' (did you mean 'left'?); "
        f"the robot's joints are yaw, left, right"
    )


def test_angle_outside_the_joint_limits_says_the_valid_range():
    path, message = only_problem("angle_outside_limits.yaml")
    assert message == f"{path}:3:18: pose: left 130° is outside its limits -60..120°"


def test_t_and_after_both_given():
    path, message = only_problem("t_and_after.yaml")
    assert message == (
        f"{path}:5:5: give at most one of t (arrival time from the motion start) "
        f"and after (delay after the previous keyframe); remove one"
    )


def test_unknown_pose_with_did_you_mean():
    path, message = only_problem("unknown_pose.yaml")
    assert message == (
        f"{path}:3:11: unknown pose 'wav' (did you mean 'wave'?); robot 'tiny' "
        f"has poses home, wave; or give joint angles as {{joint: degrees}}"
    )


@pytest.mark.parametrize(
    "keyframe, where, message",
    [
        ("after: 1.0\n    hold: 1.0e+308", "7:11", "hold must be in 0..86400 s, got 1e+308"),
        ("t: 1.0e+308", "6:8", "t must be in 0..86400 s, got 1e+308"),
        ("after: 86400.5", "6:12", "after must be in 0..86400 s, got 86400.5"),
    ],
)
def test_absurd_times_are_refused_at_their_number_with_the_range(
    tmp_path, capsys, keyframe, where, message
):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    {keyframe}\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow RuntimeWarning fails the test
        assert problems_of(path) == [f"{path}:{where}: {message}"]
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == f"choreo: error: {path}:{where}: {message}"


def test_a_velocity_below_its_documented_minimum_is_refused_at_its_number(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 30}\n    velocity: 1.0e-300\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:6:15: velocity must be in 0.01..1, got 1e-300"
    )
