"""choreo.robot.model_check: a robot file's MuJoCo model agrees with it (ranges, the home
keyframe, actuators, joint names), each disagreement at the robot file's line with the fix.
Fixtures: tests/data/bad_robots/<case>, tiny's MJCF with one mistake each."""

from __future__ import annotations

from robot_helpers import BAD, only_problem, problems_of


def test_mjcf_range_disagreeing_with_the_robot_file():
    path, message = only_problem("mjcf_range")
    assert message.startswith(
        f"{path}:10:34: joint 'right': MJCF joint 'right' in tiny.xml has "
        f"range -1.9199 1.0472 rad (-110.0..60.0°) but the robot file says "
        f"-100..60°"
    )
    assert message.endswith('e.g. range="-1.7453 1.0472"')


def test_mjcf_home_keyframe_disagreeing_with_the_home_pose():
    path, message = only_problem("mjcf_home")
    assert message.startswith(
        f"{path}:12:3: pose 'home': yaw is 10° (0.1745 rad) but the 'home' "
        f"keyframe in tiny.xml has 0.0000 rad"
    )


def test_actuated_mjcf_joint_that_no_joint_maps():
    path, message = only_problem("unmapped_actuator")
    assert message == (
        f"{path}:7:1: tiny.xml: actuator 'right' drives joint 'right', which no "
        f"joint here maps; add a joint with mjcf_joint: right, or remove the "
        f"actuator"
    )


def test_mjcf_joint_that_does_not_exist():
    path = BAD / "unknown_mjcf_joint" / "robot.yaml"
    first, second = problems_of(path)
    assert first == (
        f"{path}:7:1: tiny.xml: actuator 'left' drives joint 'left', which no joint "
        f"here maps; add a joint with mjcf_joint: left, or remove the actuator"
    )
    assert second == (
        f"{path}:9:75: joint 'left': tiny.xml has no joint 'lef' (did you mean "
        f"'left'?); its joints are yaw, left, right"
    )


def test_mjcf_that_does_not_compile_points_at_the_xml_line():
    [message] = problems_of(BAD / "mjcf_compile_error" / "robot.yaml")
    xml = BAD / "mjcf_compile_error" / "broken.xml"
    assert message.startswith(f"{xml}:5:1: MuJoCo cannot compile this model: ")
    assert "unrecognized attribute: 'rnge'" in message
