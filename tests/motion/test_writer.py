"""choreo.motion.writer: keyframes -> motion file text that reads back as the same motion (what
mirror, import and record write)."""

from __future__ import annotations

import dataclasses

import pytest
from cli_helpers import WAVE

from choreo.motion.motion_file import load_motion
from choreo.motion.writer import motion_text, robot_reference

FIELDS = ("targets_deg", "t_s", "after_s", "hold_s", "stop", "velocity_scale")


def read_back(tmp_path, text: str):
    path = tmp_path / "written.yaml"
    path.write_text(text)
    return load_motion(path)


def same_keyframes(a, b) -> None:
    assert len(a) == len(b)
    for one, other in zip(a, b):
        assert [getattr(one, f) for f in FIELDS] == [getattr(other, f) for f in FIELDS]


def test_a_shipped_motion_written_out_reads_back_the_same(tmp_path):
    wave = load_motion(WAVE)
    ref = robot_reference(wave.robot, tmp_path / "written.yaml")
    text = motion_text(wave.robot, wave.keyframes, robot_ref=ref, speed=1.5, repeat=2)
    again = read_back(tmp_path, text)
    same_keyframes(again.keyframes, wave.keyframes)
    assert (again.robot.path, again.speed, again.repeat) == (wave.robot.path, 1.5, 2)


def test_numbers_read_back_exactly_and_never_in_exponent_form(tmp_path):
    """YAML 1.1 reads 1e-05 as text: the writer writes 0.00001."""
    wave = load_motion(WAVE)
    tiny = dataclasses.replace(wave.keyframes[1], after_s=1e-05, hold_s=1 / 3)
    text = motion_text(wave.robot, [wave.keyframes[0], tiny], robot_ref="arm6")
    assert "e-" not in text and "0.00001" in text
    same_keyframes(read_back(tmp_path, text).keyframes, [wave.keyframes[0], tiny])


@pytest.mark.parametrize(
    "description",
    [
        "yes",  # YAML 1.1 would read it as true unquoted
        "waves: twice",  # a colon would make it a mapping
        "  leading spaces",
        ("a long one, " * 20).strip(),  # folded over several lines
    ],
)
def test_a_description_reads_back_unchanged(tmp_path, description):
    wave = load_motion(WAVE)
    text = motion_text(wave.robot, wave.keyframes, robot_ref="arm6", description=description)
    assert read_back(tmp_path, text).description == description
    assert all(len(line) <= 100 for line in text.splitlines())


def test_comments_go_after_a_short_keyframe_or_before_a_long_one(tmp_path):
    wave = load_motion(WAVE)
    comments = {1: "raise", 2: "a comment\nover two lines"}
    text = motion_text(wave.robot, wave.keyframes[:3], robot_ref="arm6", comments=comments)
    lines = text.splitlines()
    raised = next(i for i, line in enumerate(lines) if line.endswith("  # raise"))
    assert lines[raised + 1 : raised + 3] == ["  # a comment", "  # over two lines"]
    same_keyframes(read_back(tmp_path, text).keyframes, wave.keyframes[:3])


def test_the_robot_is_named_where_the_name_finds_it_else_by_its_path(tmp_path, monkeypatch):
    monkeypatch.delenv("CHOREO_MODELS", raising=False)
    wave = load_motion(WAVE)
    assert robot_reference(wave.robot, tmp_path / "m.yaml") == "arm6"
    shadow = tmp_path / "models" / "arm6" / "robot.yaml"  # another arm6, nearer the motion
    shadow.parent.mkdir(parents=True)
    shadow.write_text("name: arm6\n")
    ref = robot_reference(wave.robot, tmp_path / "m.yaml")
    assert ref.endswith("models/arm6/robot.yaml") and ref != "arm6"
    assert (tmp_path / ref).resolve() == wave.robot.path.resolve()
