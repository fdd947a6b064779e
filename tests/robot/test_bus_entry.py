"""The bus: block of a robot file: its values, and its ranges those of the command line."""

from __future__ import annotations

import shutil

import pytest
from cli_helpers import REPO
from paths import DATA

from choreo.bus.settings import BusSettings
from choreo.cli import main
from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot


def test_robot_file_bus_ranges_equal_the_command_line(tmp_path, capsys):
    robot = tmp_path / "arm6" / "robot.yaml"
    robot.parent.mkdir()
    for source in (REPO / "models" / "arm6").iterdir():
        (robot.parent / source.name).write_bytes(source.read_bytes())
    text = robot.read_text().replace(
        "defaults:", "bus: {retries: 10, timeout_ms: 5001}\ndefaults:", 1
    )
    robot.write_text(text)
    line = next(n for n, t in enumerate(text.splitlines(), 1) if t.startswith("bus:"))
    assert main(["validate", str(robot)]) == 1
    assert capsys.readouterr().out.splitlines() == [
        f"{robot}:{line}:16: bus: retries must be in 0..9, got 10",
        f"{robot}:{line}:32: bus: timeout_ms must be in (0, 5000], got 5001",
    ]


def tiny_with_bus(tmp_path, bus: str):
    tiny = tmp_path / "tiny"
    shutil.copytree(DATA / "models" / "tiny", tiny)
    text = (tiny / "robot.yaml").read_text()
    (tiny / "robot.yaml").write_text(text.replace("defaults:", f"bus: {bus}\ndefaults:", 1))
    return tiny / "robot.yaml"


def test_a_bus_block_is_read_into_the_robots_bus_settings(tmp_path):
    path = tiny_with_bus(
        tmp_path,
        "{port: /dev/ttyUSB1, timeout_ms: 20, retries: 4, echo: discard, supply_v: 7.4, "
        "direction: 'rx=4,tx=27'}",
    )
    assert load_robot(path).bus == BusSettings(
        port="/dev/ttyUSB1",
        timeout_s=0.02,
        retries=4,
        echo="discard",
        supply_v=7.4,
        direction="rx=4,tx=27",
    )
    assert load_robot(tiny_with_bus(tmp_path / "none", "{}")).bus == BusSettings()


def test_direction_lines_that_name_no_preset_and_no_lines_are_refused_at_their_place(tmp_path):
    path = tiny_with_bus(tmp_path, "{direction: rx=4}")
    with pytest.raises(SourceError) as error:
        load_robot(path)
    [problem] = error.value.problems
    assert problem.startswith(f"{path}:3:18: bus: direction: 'rx=4' is not a preset (")
