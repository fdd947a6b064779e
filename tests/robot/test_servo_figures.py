"""Servo figures files: each joint's actuator figures, by joint name or servo ID."""

from __future__ import annotations

import pytest

from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot, with_servo_figures
from choreo.robot.servo_figures import DEFAULT_SUPPLY_RESISTANCE_OHM, read_servo_figures
from choreo.robot.types import GaitCompensation

ARM6 = load_robot("arm6")


def test_figures_are_read_by_joint_name_and_by_servo_id(tmp_path):
    path = tmp_path / "figures.yaml"
    path.write_text(
        "supply: {voltage_v: 7.2}\n"
        "joints:\n"
        "  elbow: {backlash_deg: 0.8, friction_nm: 0.02}\n"
        "servos:\n"
        "  2: {offset_deg: -1.5, response_delay_s: 0.004}\n"
        "measured: '2026-11-26T14:00:00Z'\n"
        "validation: {median_deg: 0.3}\n"
    )
    figures = read_servo_figures(path, ARM6)
    assert dict(figures.joints["elbow"]) == {"backlash_deg": 0.8, "friction_nm": 0.02}
    assert dict(figures.joints["shoulder"]) == {"offset_deg": -1.5, "response_delay_s": 0.004}
    assert set(figures.joints) == {"elbow", "shoulder"}
    assert figures.supply_v == 7.2
    assert figures.supply_resistance_ohm == DEFAULT_SUPPLY_RESISTANCE_OHM
    assert figures.extra["measured"] == "2026-11-26T14:00:00Z"
    assert figures.extra["validation"] == {"median_deg": 0.3}


@pytest.mark.parametrize(
    "text, message",
    [
        ("joints:\n  elbo: {backlash_deg: 1}\n", r":2:3: joints: arm6 has no joint 'elbo'.*elbow"),
        ("servos:\n  9: {backlash_deg: 1}\n", r":2:3: servos: arm6 has no servo '9'"),
        (
            "joints:\n  shoulder: {backlash_deg: 1}\nservos:\n  2: {deadband_deg: 1}\n",
            r":4:3: servos: 2 is joint shoulder, given twice",
        ),
        ("joints:\n  elbow: {friction_nm: -0.1}\n", r":2:24: joints: elbow: friction_nm must be"),
        ("joints:\n  elbow: {response_delay_s: 0.5}\n", r"response_delay_s must be.*0\.1"),
        ("joints:\n  elbow: {stiffness: 3}\n", r"unknown key 'stiffness'"),
        ("supply: {voltage_v: 0}\n", r"supply: voltage_v must be"),
        ("gait: {stride_scale: 3}\n", r":1:22: gait: stride_scale must be in 0.5..2, got 3"),
        ("gait: {lift: 5}\n", r"unknown key 'lift' in gait \(did you mean 'lift_sag'\?\)"),
        ("", r":1:1: the file is empty"),
    ],
)
def test_a_problem_is_told_at_its_line(tmp_path, text, message):
    path = tmp_path / "figures.yaml"
    path.write_text(text)
    with pytest.raises(SourceError, match=message):
        read_servo_figures(path, ARM6)


def test_an_offset_may_have_either_sign(tmp_path):
    path = tmp_path / "figures.yaml"
    path.write_text("joints:\n  elbow: {offset_deg: -2.5}\n  shoulder: {offset_deg: 1}\n")
    figures = read_servo_figures(path, ARM6)
    assert figures.joints["elbow"]["offset_deg"] == -2.5


def test_a_robot_file_naming_measured_figures_uses_them_for_the_preview_and_the_planner(tmp_path):
    folder = tmp_path / "arm6"
    folder.mkdir()
    for source in (ARM6.path.parent).iterdir():
        (folder / source.name).write_bytes(source.read_bytes())
    (folder / "measured.yaml").write_text(
        "measured: '2026-11-26T14:00:00Z'\n"
        "joints:\n  elbow: {no_load_speed_deg_s: 250, backlash_deg: 0.9}\n"
    )
    text = (folder / "robot.yaml").read_text()
    (folder / "robot.yaml").write_text(
        text.replace("scene: scene.xml\n", "scene: scene.xml\nservo_figures: measured.yaml\n")
    )
    robot = load_robot(folder / "robot.yaml")
    elbow, shoulder = robot.joint("elbow"), robot.joint("shoulder")
    assert dict(elbow.actuator) == {"no_load_speed_deg_s": 250, "backlash_deg": 0.9}
    assert elbow.limits.vel_deg_s == 200  # 80 % of the measured speed
    assert shoulder.limits.vel_deg_s == ARM6.joint("shoulder").limits.vel_deg_s  # assumed
    assert robot.servo_figures is not None
    assert robot.servo_figures.extra["measured"] == "2026-11-26T14:00:00Z"
    unmeasured = load_robot(folder / "robot.yaml", with_figures=False)
    assert dict(unmeasured.joint("elbow").actuator) == {}
    (folder / "measured.yaml").unlink()
    with pytest.raises(SourceError, match="servo_figures: .*measured.yaml does not exist"):
        load_robot(folder / "robot.yaml")


def test_a_walkers_figures_carry_its_gait_compensation_which_replaces_the_robot_files(tmp_path):
    hexapod = load_robot("hexapod18", with_figures=False)
    path = tmp_path / "figures.yaml"
    path.write_text(
        "joints:\n  lf_femur: {kp_nm_rad: 12}\n"
        "gait: {lift_sag: 9.5, stride_scale: 1.1, turn_scale: 1.2}\n"
    )
    figures = read_servo_figures(path, hexapod)
    assert figures.gait == GaitCompensation(9.5, 1.1, 1.2)
    assert with_servo_figures(hexapod, figures).gait == figures.gait
    path.write_text("joints:\n  lf_femur: {kp_nm_rad: 12}\n")  # none: the robot file's
    assert with_servo_figures(hexapod, read_servo_figures(path, hexapod)).gait == hexapod.gait
