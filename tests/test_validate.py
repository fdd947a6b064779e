"""choreo validate runs every stage: load, plan, compile into ticks, physics preview."""

from __future__ import annotations

from pathlib import Path

import yaml
from cli_helpers import PREVIEW_MOTIONS

from choreo.cli import main
from choreo.validate import check_file


def write(tmp_path: Path, keyframes: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text("robot: arm6\nkeyframes:\n  - pose: home\n" + keyframes)
    return path


def test_an_unreachable_keyframe_time_fails_with_its_line(tmp_path):
    path = write(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    result = check_file(path)
    assert not result.ok
    [problem] = result.problems
    assert problem.startswith(f"{path}:4:5: keyframe cannot be reached at 0.100 s")
    assert "shoulder" in problem


def test_a_self_collision_is_reported_at_the_keyframe_heading_into_it():
    result = check_file(PREVIEW_MOTIONS / "collide.yaml")
    assert any(
        p.startswith(f"{PREVIEW_MOTIONS / 'collide.yaml'}:6:5: preview: self-collision")
        for p in result.problems
    )


def test_stretch_turns_an_unreachable_time_into_a_warning(tmp_path, capsys):
    path = write(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    result = check_file(path, stretch=True)
    assert result.ok
    [warning] = [w for w in result.warnings if "stretched" in w]
    assert (
        warning.startswith(f"{path}:4:5: stretched: reached 0.")
        and "s later than written" in warning
    )
    assert main(["validate", "--stretch", "--no-physics", str(path)]) == 0
    assert f"warning: {path}:4:5: stretched" in capsys.readouterr().out


def test_a_supply_below_the_servos_rated_range_is_told_by_validate_and_preview(tmp_path, capsys):
    """arm3 is LX-16A (rated 6-8.4 V): a 5.5 V supply is refused by `choreo play`'s preflight,
    so validate says so of the robot file and of a motion (with or without physics), and the
    preview reports it as an error; a supply inside the range passes."""
    import shutil

    models = tmp_path / "models"
    shutil.copytree(PREVIEW_MOTIONS.parent / "models" / "arm3", models / "arm3")
    robot_file = models / "arm3" / "robot.yaml"
    text = robot_file.read_text()
    motion = tmp_path / "motions" / "fine.yaml"
    motion.parent.mkdir()
    shutil.copy(PREVIEW_MOTIONS / "fine.yaml", motion)
    robot_file.write_text(text.replace("defaults:", "bus:\n  supply_v: 5.5\ndefaults:"))
    told = "yaw, shoulder, elbow: supply 5.5 V is outside the LX-16A's rated 6-8.4 V"
    assert main(["validate", str(robot_file)]) == 1
    assert told in capsys.readouterr().out
    for flags in (["--no-physics"], []):
        assert main(["validate", *flags, str(motion)]) == 1
        out = capsys.readouterr().out
        assert out.count(told) == 1, out
    assert main(["preview", "--check", str(motion)]) == 1
    out = capsys.readouterr().out
    assert f"{motion}:4:5: error: {told}: `choreo play` refuses" in out, out
    robot_file.write_text(text.replace("defaults:", "bus:\n  supply_v: 6.0\ndefaults:"))
    assert main(["validate", str(robot_file), str(motion)]) == 0
    assert "rated" not in capsys.readouterr().out


def test_a_motion_is_parsed_once_to_tell_it_from_a_show(tmp_path, monkeypatch):
    """A long motion's YAML is a good part of validating it: telling a show from a motion
    reuses the parse instead of reading the file a second time."""
    composed: list[str] = []
    compose = yaml.compose

    def counting_compose(text, Loader):  # noqa: N803 (PyYAML's name)
        composed.append(text)
        return compose(text, Loader=Loader)

    monkeypatch.setattr(yaml, "compose", counting_compose)
    motion = write(tmp_path, "  - pose: {shoulder: 10}\n    t: 1.0\n")
    assert check_file(motion, physics=False).ok
    assert composed.count(motion.read_text()) == 1
