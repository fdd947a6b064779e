"""The joints of a robot file: each mistake in a joint reported at its place, and what a joint may
override (fixtures: tests/data/bad_robots/<case>)."""

from __future__ import annotations

import shutil

import pytest
from paths import DATA
from robot_helpers import only_problem

from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot


def test_duplicate_servo_id():
    path, message = only_problem("duplicate_id")
    assert message == (
        f"{path}:9:14: joint 'left': servo id 2 is already used by joint 'yaw' "
        f"(line 8); each joint needs its own id 0..253"
    )


def test_limit_outside_servo_travel_says_the_reachable_range():
    path, message = only_problem("outside_travel")
    assert message == (
        f"{path}:14:10: joint 'right': max 130° is outside the servo's travel: it "
        f"needs servo position 1166.7, outside 0..1000 (0..240°); with zero 625 "
        f"and direction 1 this joint can reach -150..90°"
    )


def test_unknown_servo_model_lists_the_known_ones():
    path, message = only_problem("unknown_servo")
    assert message == (
        f"{path}:6:10: defaults: servo: unknown servo model 'LX16A' (did you mean "
        f"'LX-16A'?); known models: LX-16A, LX-224HV, LX-824HV, HTD-35H, LX-224, "
        f"LX-225, LX-15D"
    )


def test_velocity_above_the_servos_no_load_speed():
    path, message = only_problem("too_fast")
    assert message == (
        f"{path}:8:45: joint 'yaw': velocity 400 deg/s is above the LX-16A's "
        f"no-load speed of 375 deg/s; give at most 375 (the default is 300)"
    )


def test_a_joint_can_override_the_preview_actuator_of_its_servo(tmp_path):
    tiny = tmp_path / "tiny"
    shutil.copytree(DATA / "models" / "tiny", tiny)
    text = (tiny / "robot.yaml").read_text()
    (tiny / "robot.yaml").write_text(
        text.replace(
            "    velocity: 200\n",
            "    velocity: 200\n    actuator: {stall_torque_nm: 0.8, damping_nm_s_rad: 0.1}\n",
        )
    )
    robot = load_robot(tiny / "robot.yaml")
    assert dict(robot.joint("right").actuator) == {"stall_torque_nm": 0.8, "damping_nm_s_rad": 0.1}
    assert dict(robot.joint("left").actuator) == {}
    (tiny / "robot.yaml").write_text(
        text.replace(
            "    velocity: 200\n",
            "    velocity: 200\n    actuator: {stall_torque: 0.8, kp_nm_rad: 0}\n",
        )
    )
    with pytest.raises(SourceError) as error:
        load_robot(tiny / "robot.yaml")
    [unknown, zero] = error.value.problems
    assert (
        "unknown key 'stall_torque' in joint 'right': actuator (did you mean "
        "'stall_torque_nm'?)" in unknown
    )
    assert "joint 'right': actuator: kp_nm_rad must be > 0, got 0" in zero
