"""choreo identify as a user runs it: a line per joint, the file and how to use it, the joints a
motion moves, and a joint that is not there (short moves and search: the fit is judged in
tests/identify/)."""

from __future__ import annotations

import pytest
import yaml
from cli_helpers import error_line, motion_file
from identify_helpers import make_identify_quick

from choreo.cli import main


@pytest.fixture
def quick(monkeypatch):
    """Short test moves and a short search (identify_helpers.py)."""
    make_identify_quick(monkeypatch)


def test_the_command_prints_a_line_per_joint_and_how_to_use_the_file(tmp_path, quick, capsys):
    output = tmp_path / "figures.yaml"
    port = ["--port", "sim://?physics=arm6"]
    assert main(["identify", "arm6", "--joints", "wrist_roll", "-o", str(output), *port]) == 0
    out = capsys.readouterr().out
    assert "wrist_roll: dead band" in out and "held-out error median" in out
    assert f"wrote {output}: 1 joint(s)" in out
    assert "servo_figures:" in out
    assert main(["identify", "arm6", "--joints", "elbo", "-o", str(output), *port]) == 2
    assert "choreo: error: --joints names elbo" in error_line(capsys)


def test_a_motion_names_the_joints_it_moves(tmp_path, quick, capsys):
    # two of arm6's six, named out of the robot's order: each joint measured costs 0.5 s of CPU
    motion = motion_file(tmp_path, "  - pose: {gripper: 30, elbow: -20}\n    t: 1\n")
    output = tmp_path / "figures.yaml"
    port = ["--port", "sim://?physics=arm6"]
    assert main(["identify", str(motion), "-o", str(output), *port]) == 0
    measured = yaml.safe_load(output.read_text())["joints"]
    assert list(measured) == ["elbow", "gripper"]  # what the motion moves, in the robot's order


def test_a_walker_is_told_its_recalibrated_gait_compensation(tmp_path, quick, capsys, monkeypatch):
    import sys

    from choreo.robot.types import GaitCompensation

    identify_module = sys.modules["choreo.identify.identify"]
    monkeypatch.setattr(
        identify_module, "calibrated_gait", lambda robot: GaitCompensation(8, 1.1, 1.2)
    )
    output = tmp_path / "figures.yaml"
    port = ["--port", "sim://?physics=hexapod18&stand=1"]
    assert main(["identify", "hexapod18", "--joints", "lf_tibia", "-o", str(output), *port]) == 0
    out = capsys.readouterr().out
    assert (
        f"gait compensation recalibrated in the preview with these figures (in {output}): "
        "lift +8 mm, stride x1.1, turn x1.2"
    ) in out


def test_a_joint_whose_neighbours_gave_way_under_it_says_so(tmp_path, quick, capsys, monkeypatch):
    import sys

    from choreo.identify.joint_model import SentMove
    from choreo.identify.moves import MovePlan

    def full_speed(joint, pose_deg, drop=False, loaded=()):  # steps the elbow's stall torque drives
        steps = (SentMove(0.0, pose_deg + 20.0, 0.0), SentMove(0.5, pose_deg - 20.0, 0.0))
        return MovePlan(steps, 1.0)

    identify_module = sys.modules["choreo.identify.identify"]
    monkeypatch.setattr(identify_module, "fit_moves", full_speed)
    output = tmp_path / "figures.yaml"
    port = ["--port", "sim://?physics=arm6"]
    assert main(["identify", "arm6", "--joints", "elbow", "-o", str(output), *port]) == 0
    out = " ".join(capsys.readouterr().out.split())  # as one line: the console wraps
    assert "reads/s (" in out and " its own)" in out
    assert out.count("gave way") == 1
    assert "elbow's neighbours gave way under its moves (up to shoulder " in out
    assert "the fit replayed their measured motion" in out
    # a joint whose neighbours hold firm under it (crossed axes: none read) says nothing
    assert main(["identify", "arm6", "--joints", "base_yaw", "-o", str(output), *port]) == 0
    assert "gave way" not in capsys.readouterr().out
