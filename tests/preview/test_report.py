"""The preview says where every servo figure it used comes from: the datasheet, modelling
choices, assumptions, the robot file, or measured on the robot (and when) by choreo identify."""

from __future__ import annotations

import shutil

from paths import DATA

from choreo.preview import preview_report, simulate, start_lines
from choreo.robot.robot_file import load_robot

ARM3 = DATA / "preview" / "models" / "arm3"


def test_every_servo_figure_is_named_assumed_with_its_source_and_the_robot_files_own(tmp_path):
    shutil.copytree(ARM3, tmp_path / "arm3")
    robot_file = tmp_path / "arm3" / "robot.yaml"
    text = robot_file.read_text()
    rollout = simulate(load_robot(robot_file), [], [0, 0, 0])
    (line,) = [x for x in start_lines(rollout) if x.startswith("servo figures: ")]
    assert line == (
        "servo figures: all assumed (not measured on this robot); stall torque, no-load speed: "
        "datasheet; gain, damping, armature: modelling choice; supply: rated; dead band, "
        "backlash: assumed; friction, response delay, offset: assumed none"
    )
    robot_file.write_text(
        text.replace("defaults:", "bus:\n  supply_v: 7.0\ndefaults:").replace(
            "elbow:    {id: 3, min: -110, max: 110}",
            "elbow:    {id: 3, min: -110, max: 110, actuator: {backlash_deg: 1.2}}",
        )
    )
    rollout = simulate(load_robot(robot_file), [], [0, 0, 0])
    (line,) = [x for x in start_lines(rollout) if x.startswith("servo figures: ")]
    assert "supply, backlash (elbow): robot file" in line
    assert "dead band, backlash (yaw, shoulder): assumed" in line
    figures = preview_report(rollout, [])["assumptions"]["figures"]
    assert {(f["figure"], f["source"]) for f in figures if "elbow" in f["joints"]} >= {
        ("backlash_deg", "robot file"),
        ("stall_torque_nm", "datasheet"),
    }
    assert not any(f["measured"] or f["measured_on"] for f in figures)


def test_figures_measured_by_identify_are_named_measured_with_when_and_the_rest_assumed(tmp_path):
    shutil.copytree(ARM3, tmp_path / "arm3")
    robot_file = tmp_path / "arm3" / "robot.yaml"
    (tmp_path / "arm3" / "servos.yaml").write_text(
        "robot: arm3\n"
        "measured: '2026-11-26T14:00:00Z'\n"
        "joints:\n"
        "  yaw: {deadband_deg: 0.3, backlash_deg: 0.9, friction_nm: 0.02}\n"
        "  shoulder: {deadband_deg: 0.4, backlash_deg: 0.7, friction_nm: 0.01}\n"
        "  elbow: {deadband_deg: 0.2, backlash_deg: 1.1, response_delay_s: 0.01}\n"
    )
    robot_file.write_text(robot_file.read_text() + "servo_figures: servos.yaml\n")
    rollout = simulate(load_robot(robot_file), [], [0, 0, 0])
    (line,) = [x for x in start_lines(rollout) if x.startswith("servo figures: ")]
    assert line == (
        "servo figures: dead band, backlash, friction (yaw, shoulder), response delay (elbow): "
        "measured 2026-11-26T14:00:00Z (servos.yaml); still assumed: stall torque, no-load "
        "speed: datasheet; gain, damping, armature: modelling choice; supply: rated; response "
        "delay (yaw, shoulder), offset, friction (elbow): assumed none"
    )
    figures = preview_report(rollout, [])["assumptions"]["figures"]
    measured = {(f["figure"], j) for f in figures if f["measured"] for j in f["joints"]}
    assert ("backlash_deg", "elbow") in measured and ("friction_nm", "yaw") in measured
    assert ("friction_nm", "elbow") not in measured
    assert {f["measured_on"] for f in figures if f["measured"]} == {"2026-11-26T14:00:00Z"}
    assert {f["source"] for f in figures if f["measured"]} == {"servos.yaml"}
    assert not any(f["measured_on"] for f in figures if not f["measured"])


def test_a_figures_file_that_does_not_say_when_it_was_measured_is_named_but_not_measured(
    tmp_path,
):
    shutil.copytree(ARM3, tmp_path / "arm3")
    robot_file = tmp_path / "arm3" / "robot.yaml"
    (tmp_path / "arm3" / "servos.yaml").write_text("joints:\n  elbow: {backlash_deg: 1.1}\n")
    robot_file.write_text(robot_file.read_text() + "servo_figures: servos.yaml\n")
    rollout = simulate(load_robot(robot_file), [], [0, 0, 0])
    (line,) = [x for x in start_lines(rollout) if x.startswith("servo figures: ")]
    assert line.startswith("servo figures: all assumed (not measured on this robot); ")
    assert "backlash (elbow): servos.yaml" in line
