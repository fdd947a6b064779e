"""A joint as robot.yaml writes it: a check made after reading still points at the line that
wrote each value, even a value the joint takes from ``defaults:``."""

from __future__ import annotations

import shutil

import pytest
from paths import DATA

from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot


def test_a_limit_taken_from_defaults_is_blamed_where_defaults_writes_it(tmp_path):
    folder = tmp_path / "tiny"
    shutil.copytree(DATA / "models" / "tiny", folder)
    robot = folder / "robot.yaml"
    text = robot.read_text()
    text = text.replace("  servo: LX-16A\n", "  servo: LX-16A\n  min: -80\n", 1)
    robot.write_text(text.replace("    id: 1\n    min: -90\n", "    id: 1\n", 1))
    with pytest.raises(SourceError) as refused:
        load_robot(robot)
    [problem] = refused.value.problems
    # line 5 is defaults' "min: -80", not the yaw joint's own lines (7-9)
    assert problem.startswith(
        f"{robot}:5:8: joint 'yaw': MJCF joint 'yaw' in tiny.xml has range -1.5708 1.5708 rad"
    )
    assert "but the robot file says -80..90°" in problem
