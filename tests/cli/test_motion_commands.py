"""choreo validate as a user runs it: every stage, the exit code and the lines printed."""

from __future__ import annotations

from cli_helpers import PREVIEW_MOTIONS

from choreo.cli import main


def test_physics_can_be_skipped(capsys):
    assert main(["validate", "--no-physics", str(PREVIEW_MOTIONS / "collide.yaml")]) == 0
    assert main(["validate", str(PREVIEW_MOTIONS / "collide.yaml")]) == 1
    assert "self-collision" in capsys.readouterr().out


def test_a_fine_motion_and_a_robot_pass(capsys):
    assert main(["validate", str(PREVIEW_MOTIONS / "fine.yaml"), "models/arm6/robot.yaml"]) == 0
    out = capsys.readouterr().out
    assert f"{PREVIEW_MOTIONS / 'fine.yaml'}: ok" in out and "models/arm6/robot.yaml: ok" in out
