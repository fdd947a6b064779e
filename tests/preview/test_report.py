"""The preview says where every servo figure it used comes from, and that none is measured on
the robot yet: the datasheet, modelling choices, assumptions, or the robot file."""

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
        "backlash: assumed"
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
