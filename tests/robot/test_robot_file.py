"""Robot files: loading, every class of mistake reported at its place, mirroring.

Fixtures: tests/data/models/tiny (a good three-joint robot) and tests/data/bad_robots/<case>
(each with one kind of mistake, reusing tiny's MJCF unless the case is about the MJCF).
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest
from cli_helpers import REPO
from paths import DATA
from robot_helpers import BAD, only_problem, problems_of

from choreo.cli import main
from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot
from choreo.robot.types import mirror_pose, mirror_targets

TINY = DATA / "models" / "tiny" / "robot.yaml"
# --- a good robot --------------------------------------------------------------------------------


def test_tiny_robot_is_read_with_defaults_and_overrides():
    robot = load_robot(TINY)
    assert robot.name == "tiny"
    assert robot.joint_names == ("yaw", "left", "right")  # file order is vector order
    assert [j.servo_id for j in robot.joints] == [1, 2, 3]
    assert {j.servo_model for j in robot.joints} == {"LX-16A"}  # from defaults
    yaw, left, right = robot.joints
    assert (yaw.zero_units, yaw.direction) == (500, 1)  # format defaults
    assert (left.zero_units, left.direction) == (625, -1)
    assert (left.limits.min_deg, left.limits.max_deg) == (-60, 120)
    # LX-16A: 80 % of 375 deg/s (servo-models.md: 300 deg/s), 3000 deg/s², 30000 deg/s³
    assert (yaw.limits.vel_deg_s, yaw.limits.acc_deg_s2, yaw.limits.jerk_deg_s3) == pytest.approx(
        (300, 3000, 30000)
    )
    assert right.limits.vel_deg_s == 200  # overridden in the file
    assert left.to_units(120) == pytest.approx(125)  # 625 - 120 * 1000/240
    assert left.limits_units == pytest.approx((125, 875))  # 120° and -60°: the lower first
    assert robot.pose_vector("wave") == (30, 90, 0)
    assert dict(robot.poses["home"]) == {"yaw": 0, "left": 0, "right": 0}
    assert [(p.left, p.right, p.sign) for p in robot.mirror_pairs] == [
        ("left", "right", -1),
        ("yaw", "yaw", -1),
    ]
    assert (robot.bus.port, robot.bus.timeout_s) == (None, 0.05)
    assert robot.mjcf_path.name == "tiny.xml" and robot.scene_path.name == "scene.xml"
    assert robot.free_floating is False


def test_poses_cannot_be_changed_through_the_robot():
    robot = load_robot(TINY)
    with pytest.raises(TypeError):
        robot.poses["home"]["yaw"] = 5


def test_the_robot_finds_its_joints_by_name_and_lends_them_read_only():
    robot = load_robot(TINY)
    assert list(robot.joints_by_name) == ["yaw", "left", "right"]
    assert robot.joints_by_name["left"] is robot.joints[1] is robot.joint("left")
    with pytest.raises(TypeError):
        robot.joints_by_name["left"] = robot.joints[0]  # type: ignore[index]
    with pytest.raises(KeyError, match="elbow"):
        robot.joint("elbow")


def test_the_robot_converts_every_joint_at_once():
    robot = load_robot(TINY)  # zero/direction: yaw 500/+1, left 625/-1, right 625/+1
    angles = [[24, 120, -60], [0, 0, 0]]
    expected = [[600, 125, 375], [500, 625, 625]]  # zero + direction * angle * 1000/240
    assert robot.to_units(angles) == pytest.approx(np.array(expected))
    assert robot.to_deg(expected) == pytest.approx(np.array(angles))
    assert robot.to_units(angles)[0].tolist() == [
        j.to_units(a) for j, a in zip(robot.joints, angles[0])
    ]


def test_the_robot_checks_the_joint_limits_ends_included():
    robot = load_robot(TINY)  # limits: yaw -90..90, left -60..120, right -110..60
    poses = [[-90, 120, 60], [91, -61, 60], [float("nan"), 0, -110.5]]
    assert robot.outside_limits(poses).tolist() == [
        [False, False, False],
        [True, True, False],
        [True, False, True],
    ]
    assert [str(v) for v in robot.limit_violations(poses[1])] == [
        "yaw at 91° is outside its limits -90..90°",
        "left at -61° is outside its limits -60..120°",
    ]
    [outside] = robot.limit_violations({"right": 61, "yaw": 0})  # a partial pose, by name
    assert (outside.joint.name, outside.angle_deg) == ("right", 61)
    with pytest.raises(ValueError, match="2 angles for the 3 joints of tiny"):
        robot.limit_violations([0, 0])


# --- one test per class of mistake ---------------------------------------------------------------


def test_mirror_pair_naming_an_unknown_joint():
    path, message = only_problem("mirror_unknown_joint")
    assert message == (
        f"{path}:14:25: mirror: right: unknown joint 'rigth' (did you mean "
        f"'right'?); the robot's joints are yaw, left, right"
    )


def test_malformed_yaml_is_a_message_not_a_traceback():
    path, message = only_problem("malformed")
    assert message.startswith(f"{path}:5:6: not valid YAML: ")  # then PyYAML's words
    assert "\n" not in message and "<unicode string>" not in message


def test_name_must_equal_the_folder():
    path, message = only_problem("name_mismatch")
    assert message.startswith(
        f"{path}:2:7: name 'tiny' must equal the robot's folder name 'name_mismatch'"
    )


def test_every_problem_of_a_file_is_reported_at_once():
    path = BAD / "several_problems" / "robot.yaml"
    assert problems_of(path) == [
        f"{path}:6:12: bus: retries must be a whole number in 0..9, got 'fast'",
        f"{path}:7:9: bus: echo 'discrad' is not one of none, discard, auto "
        f"(did you mean 'discard'?)",
        f"{path}:10:3: unknown key 'colour' in defaults; valid keys: servo, zero, direction, "
        f"min, max, velocity, acceleration, jerk, mjcf_joint, actuator",
        f"{path}:12:13: joint 'yaw': id must be in 0..253, got 254",
        f"{path}:13:39: joint 'left': direction must be 1 or -1, got 2",
        f"{path}:14:34: joint 'right': min 60° must be below max -110°",
        f"{path}:18:38: mirror: sign must be 1 or -1, got 0",
    ]


def test_missing_robot_file_is_a_source_error(tmp_path):
    missing = tmp_path / "robot.yaml"
    with pytest.raises(SourceError, match="robot file '.*robot.yaml' not found"):
        load_robot(missing)


def test_missing_mjcf_file(tmp_path):
    folder = tmp_path / "lonely"
    folder.mkdir()
    (folder / "robot.yaml").write_text(TINY.read_text().replace("name: tiny", "name: lonely"))
    messages = problems_of(folder / "robot.yaml")
    assert messages == [
        f"{folder / 'robot.yaml'}:1:1: the MuJoCo model {folder / 'lonely.xml'} does not exist; "
        f"add it beside robot.yaml",
        f"{folder / 'robot.yaml'}:1:1: the scene {folder / 'scene.xml'} does not exist; "
        f"add it beside robot.yaml",
    ]


# --- mirroring -----------------------------------------------------------------------------------


def test_mirror_swaps_pairs_with_their_sign_and_negates_self_pairs():
    robot = load_robot(TINY)
    # pairs: left<->right with sign -1, yaw with itself, sign -1
    assert mirror_targets(robot, (10.0, 20.0, -30.0)) == (-10.0, 30.0, -20.0)


def test_mirroring_twice_gives_the_pose_back():
    robot = load_robot(TINY)
    targets = (12.5, 100.0, -45.0)
    assert mirror_targets(robot, mirror_targets(robot, targets)) == targets


def test_mirror_of_a_partial_pose_moves_only_the_partner():
    robot = load_robot(TINY)
    assert mirror_pose(robot, {"left": 90}) == {"right": -90}


def test_mirror_targets_needs_one_value_per_joint():
    with pytest.raises(ValueError, match="robot 'tiny' has 3 joints"):
        mirror_targets(load_robot(TINY), (1.0, 2.0))


def test_every_robot_file_problem_is_reported_at_once(tmp_path, capsys):
    """The bus, a joint (two problems), a pose and the model file: one run, every line."""
    robot = tmp_path / "arm6" / "robot.yaml"
    robot.parent.mkdir()
    for source in (REPO / "models" / "arm6").iterdir():
        (robot.parent / source.name).write_bytes(source.read_bytes())
    text = (
        robot.read_text()
        .replace("mjcf: arm6.xml", "mjcf: nothere.xml")
        .replace("defaults:", "bus: {retries: 100}\ndefaults:", 1)
        .replace(
            "base_yaw:    {id: 1, zero: 500, direction: 1, min: -120, max: 120}",
            "base_yaw:    {id: 1, zero: 500, direction: 2, min: 120, max: -120}",
        )
        .replace("rest:  {base_yaw: 0,", "rest:  {base_yw: 0,")
    )
    robot.write_text(text)
    assert main(["validate", str(robot)]) == 1
    assert [line.split(": ", 1)[1] for line in capsys.readouterr().out.splitlines()] == [
        f"the MuJoCo model {robot.parent / 'nothere.xml'} does not exist",
        "bus: retries must be in 0..9, got 100",
        "joint 'base_yaw': direction must be 1 or -1, got 2",
        "joint 'base_yaw': min 120° must be below max -120°",  # not hidden by the direction
        "pose 'rest' does not give base_yaw; every pose names every joint",
        "pose 'rest': unknown joint 'base_yw' (did you mean 'base_yaw'?); the robot's joints are "
        "base_yaw, shoulder, elbow, wrist_pitch, wrist_roll, gripper",
    ]


def test_a_fifo_given_as_a_robot_file_is_named_so(tmp_path):
    fifo = tmp_path / "robot.yaml"
    os.mkfifo(fifo)
    with pytest.raises(SourceError, match=r"'.*robot.yaml' is a FIFO \(named pipe\), not a robot"):
        load_robot(fifo)


def test_a_robot_file_says_what_its_gaits_make_up_for(tmp_path):
    hexapod = load_robot(REPO / "models" / "hexapod18" / "robot.yaml").gait
    assert (hexapod.lift_sag_mm, hexapod.stride_scale, hexapod.turn_scale) == (7, 1.06, 1.16)
    tiny = load_robot(TINY).gait  # no gait: block: nothing added
    assert (tiny.lift_sag_mm, tiny.stride_scale, tiny.turn_scale) == (0, 1, 1)
    folder = tmp_path / "tiny"
    shutil.copytree(DATA / "models" / "tiny", folder)
    text = (folder / "robot.yaml").read_text()
    (folder / "robot.yaml").write_text(text + "gait: {lift_sag: -2, stride: 1.1, turn_scale: 3}\n")
    sag, unknown, turn = problems_of(folder / "robot.yaml")  # in the file's order
    assert sag.endswith("robot.yaml:28:18: gait: lift_sag must be in 0..100, got -2")
    assert "unknown key 'stride' in gait (did you mean 'stride_scale'?)" in unknown
    assert "gait: turn_scale must be in 0.5..2, got 3" in turn
