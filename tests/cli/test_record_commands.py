"""choreo record as a user runs it: on the built-in bus, its usage errors, and nothing limp before
the output is known good."""

from __future__ import annotations

import io

from choreo.cli import main
from choreo.motion.motion_file import load_motion
from choreo.play.recording import journal_path


def test_cli_records_on_the_built_in_bus(tmp_path, monkeypatch, capsys):
    out = tmp_path / "home.yaml"
    monkeypatch.setattr("sys.stdin", io.StringIO("\n\nq\n"))
    assert main(["record", str(out), "--robot", "arm6", "--joints", "shoulder,elbow"]) == 0
    captured = capsys.readouterr()
    assert "built-in emulated bus" in captured.err
    assert "unloaded, pose by hand: shoulder, elbow; holding: base_yaw, wrist_pitch" in captured.out
    assert f"saved {out}: 2 keyframe(s) from 2 capture(s)" in captured.out
    assert len(load_motion(out).keyframes) == 2


def test_cli_needs_a_robot_unless_resuming(tmp_path, capsys):
    assert main(["record", str(tmp_path / "t.yaml")]) == 2
    assert "--robot is required" in capsys.readouterr().err


def test_cli_an_unknown_joint_is_a_usage_error_and_leaves_no_journal(tmp_path, capsys):
    out = tmp_path / "t.yaml"
    assert main(["record", str(out), "--robot", "arm6", "--joints", "elbw"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "choreo: error: --joints names an unknown joint 'elbw' (did you mean 'elbow'?); arm6's "
        "joints are base_yaw, shoulder, elbow, wrist_pitch, wrist_roll, gripper"
    )
    assert not journal_path(out).exists()


def test_a_folder_as_the_output_is_refused_before_any_joint_goes_limp(
    tmp_path, monkeypatch, capsys
):
    out = tmp_path / "taught.yaml"
    out.mkdir()
    monkeypatch.setattr("sys.stdin", io.StringIO("\nq\n"))
    assert main(["record", str(out), "--robot", "arm6", "--overwrite"]) == 1
    captured = capsys.readouterr()
    assert captured.err.endswith(f"choreo: error: cannot write {out}: it is a folder, not a file\n")
    assert "unloaded" not in captured.out
    assert list(tmp_path.iterdir()) == [out]  # no journal either
