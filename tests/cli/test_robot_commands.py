"""`choreo robots` as a user runs it: every robot, one robot's joints, an unknown name."""

from __future__ import annotations

from cli_helpers import error_line

from choreo.cli import main


def test_robots_lists_every_robot_with_its_joints_and_poses(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == [
        "arm6: 6 joints, poses home, rest, ready (models/arm6/robot.yaml)",
        "hexapod18: 18 joints, poses home, lying, crouch (models/hexapod18/robot.yaml)",
        "tonypi: 18 joints, poses home, straight, squat (models/tonypi/robot.yaml)",
    ]


def test_robots_name_shows_limits_and_pose_angles(capsys):
    from choreo.robot.robot_file import load_robot

    assert main(["robots", "arm6"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "arm6 (models/arm6/robot.yaml)"
    rows = {line.split()[0]: line.replace("│", " ").split() for line in out[3:]}
    robot = load_robot("arm6")
    for joint in robot.joints:
        home, rest, ready = (robot.poses[p][joint.name] for p in ("home", "rest", "ready"))
        assert rows[joint.name] == [
            joint.name,
            str(joint.servo_id),
            "LX-16A",
            f"{joint.limits.min_deg:g}",
            f"{joint.limits.max_deg:g}",
            "300",
            "3000",
            "30000",
            f"{home:g}",
            f"{rest:g}",
            f"{ready:g}",
        ]
    assert out[-1] == "mirror: base_yaw <-> base_yaw (sign -1), wrist_roll <-> wrist_roll (sign -1)"


def test_robots_with_an_unknown_name_is_one_line(capsys):
    assert main(["robots", "armx"]) == 1
    assert error_line(capsys).startswith(
        "choreo: error: unknown robot 'armx' (did you mean 'arm6'?)"
    )
