"""Motion files: flattening, includes, mirroring, every class of mistake at its place; validate.

Fixtures: tests/data/motions (good motions for the tiny robot) and tests/data/bad_motions (each
with one kind of mistake; parts/ holds the files they include).
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import error_line, motion_file
from fifo_helpers import fifo_that_never_blocks
from motion_helpers import BAD, GOOD, only_problem, problems_of
from paths import DATA, REPO

from choreo.cli import main
from choreo.motion.motion_file import load_motion

# --- good motions --------------------------------------------------------------------------------


def test_header_values():
    motion = load_motion(GOOD / "wave.yaml")
    assert (motion.name, motion.speed, motion.repeat) == ("wave", 1.5, 2)
    assert motion.description == "Wave with the left arm, then the right"
    assert motion.robot.name == "tiny"
    assert motion.path == GOOD / "wave.yaml"


def test_name_defaults_to_the_file_stem():
    assert load_motion(GOOD / "timed_include.yaml").name == "timed_include"


def test_partial_poses_keep_previous_targets_and_start_from_home():
    keyframes = load_motion(GOOD / "wave.yaml").keyframes
    # joint order yaw, left, right; home is all zeros
    assert [k.targets_deg for k in keyframes[:3]] == [(0, 0, 0), (0, 90, 0), (20, 60, 0)]
    assert [k.label for k in keyframes[:3]] == ["home", "", ""]


def test_loading_does_not_depend_on_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert load_motion(GOOD / "wave.yaml").robot.name == "tiny"


def test_robot_found_through_choreo_models(tmp_path, monkeypatch):
    motion = tmp_path / "hello.yaml"
    motion.write_text("robot: tiny\nkeyframes:\n  - pose: wave\n")
    monkeypatch.setenv("CHOREO_MODELS", str(DATA / "models"))
    assert load_motion(motion).keyframes[0].targets_deg == (30, 90, 0)
    monkeypatch.delenv("CHOREO_MODELS")
    assert "unknown robot 'tiny'" in problems_of(motion)[0]


# --- one test per class of mistake ---------------------------------------------------------------


def test_wrong_type():
    path, message = only_problem("wrong_type.yaml")
    assert message == f"{path}:4:12: after must be a number in 0..86400 s, got 'soon'"


def test_unknown_key_with_did_you_mean():
    path, message = only_problem("unknown_key.yaml")
    assert message == (
        f"{path}:4:5: unknown key 'hodl' in a keyframe (did you mean 'hold'?); "
        f"valid keys: pose, sites, body, hold, stop, velocity, t, after, beat, bar"
    )


def test_unknown_robot_lists_the_known_robots():
    path, message = only_problem("unknown_robot.yaml")
    assert message.startswith(
        f"{path}:1:8: unknown robot 'tinny' (did you mean 'tiny'?); known robots: "
    )
    assert "tiny" in message.split("known robots: ")[1]


def test_malformed_yaml_is_a_message_not_a_traceback():
    path, message = only_problem("malformed.yaml")
    assert message.startswith(f"{path}:4:4: not valid YAML: ")  # then PyYAML's words
    assert "\n" not in message and "<unicode string>" not in message


def test_empty_file():
    path, message = only_problem("empty.yaml")
    assert message == f"{path}:1:1: the file is empty; a motion needs robot and keyframes"


def test_missing_file(tmp_path):
    missing = tmp_path / "nothing.yaml"
    assert problems_of(missing) == [
        f"{missing}:1:1: cannot read the file: {os.strerror(errno.ENOENT)}"  # the system's words
    ]


def test_every_problem_of_a_file_is_reported_at_once():
    path = BAD / "several_problems.yaml"
    assert problems_of(path) == [
        f"{path}:3:8: speed must be in 0.01..100, got 0",
        f"{path}:4:9: repeat must be a whole number >= 1, got 1.5",
        f"{path}:6:17: pose: yaw 200° is outside its limits -90..90°",
        f"{path}:6:22: pose: unknown joint 'elbow'; the robot's joints are yaw, left, right",
        f"{path}:8:15: velocity must be in 0.01..1, got 1.5",
        f"{path}:9:11: stop must be true or false, got 'yes please'",
        f"{path}:12:11: stop: false contradicts hold 1: a hold always comes to rest; "
        f"remove stop: false",
        f"{path}:13:14: include: {BAD / 'missing_part.yaml'} does not exist (paths are relative "
        f"to this file's folder)",
        f"{path}:15:5: a keyframe: 'pose' is given twice (first at line 14); keep one",
    ]


def test_problems_of_the_robot_are_reported_from_the_motion(tmp_path):
    motion = tmp_path / "m.yaml"
    robot = DATA / "bad_robots" / "too_fast" / "robot.yaml"
    motion.write_text(f"robot: {robot}\nkeyframes:\n  - pose: home\n")
    first, second = problems_of(motion)
    assert first.startswith(f"{motion}:1:8: robot {robot} has problems (listed after this line)")
    assert second.startswith(f"{robot}:8:45: joint 'yaw': velocity 400 deg/s")


# --- choreo validate -----------------------------------------------------------------------------


def test_validate_prints_ok_per_good_file_and_exits_0(capsys):
    robot = DATA / "models" / "tiny" / "robot.yaml"
    assert main(["validate", str(GOOD / "simple.yaml"), str(robot)]) == 0
    assert capsys.readouterr().out.splitlines() == [f"{GOOD / 'simple.yaml'}: ok", f"{robot}: ok"]


def test_validate_prints_every_problem_and_exits_1(capsys):
    good, bad = GOOD / "simple.yaml", BAD / "several_problems.yaml"
    bad_robot = DATA / "bad_robots" / "duplicate_id" / "robot.yaml"
    assert main(["validate", str(good), str(bad), str(bad_robot)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"{good}: ok"
    assert len(lines) == 1 + 9 + 1
    assert lines[1].startswith(f"{bad}:3:8: ") and lines[-1].startswith(f"{bad_robot}:9:14: ")


# --- the shipped robots and motions (models/, motions/) ------------------------------------------

SHIPPED = sorted((REPO / "models").glob("*/robot.yaml")) + sorted(
    (REPO / "motions").glob("*/*.yaml")
)


def test_shipped_files_exist():
    assert {p.parent.name for p in SHIPPED if p.name == "robot.yaml"} >= {"arm6", "hexapod18"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(REPO)))
def test_every_shipped_robot_and_motion_validates(path, capsys):
    # without its physics preview: test_the_shipped_motions_pass
    # (tests/preview/test_preview_shipped.py) simulates every shipped motion (the same
    # simulate_motion and run_checks), stricter: no warning either
    assert main(["validate", "--no-physics", str(path)]) == 0, capsys.readouterr().out


def test_repeat_is_bounded_at_its_line(tmp_path, capsys):
    path = motion_file(
        tmp_path, "  - pose: {shoulder: 30}\n    after: 1\n", head="repeat: 100000000\n"
    )
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:3:9: repeat 100000000 x 2 keyframe(s) = 200000000 keyframes to "
        "play; at most 10000 are played in one motion: at most 5000 times"
    )


def test_a_folder_fifo_or_device_given_as_a_motion_is_named_so(tmp_path):
    assert problems_of(tmp_path) == [
        f"{tmp_path}:1:1: cannot read the file: it is a folder, not a file"
    ]
    assert problems_of(Path("/dev/null")) == [
        "/dev/null:1:1: cannot read the file: it is a device, not a file"
    ]
    with fifo_that_never_blocks(tmp_path / "wave.yaml") as fifo:
        assert problems_of(fifo) == [
            f"{fifo}:1:1: cannot read the file: it is a FIFO (named pipe), not a file"
        ]


def test_more_keyframes_than_a_motion_plays_without_repeat_is_one_line(tmp_path):
    path = tmp_path / "m.yaml"
    poses = "".join(f"  - pose: {{wrist_roll: {(-1) ** i * 10}}}\n" for i in range(10_001))
    path.write_text("robot: arm6\nkeyframes:\n" + poses)
    assert problems_of(path) == [
        f"{path}:2:1: 10001 keyframes to play; at most 10000 are played in one motion: split it "
        "into shorter motions"
    ]


def test_a_file_nested_deeper_than_any_motion_is_refused_before_the_c_loader(tmp_path):
    path = tmp_path / "deep.yaml"
    path.write_text("robot: [" + "[" * 30_000 + "\n")  # the 65th level opens at column 71
    # in a child process: before the bound, libyaml's recursion crashed the interpreter
    done = subprocess.run(
        [sys.executable, "-m", "choreo", "validate", "--no-physics", str(path)],
        capture_output=True,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        check=False,
    )
    assert (done.returncode, done.stdout, done.stderr) == (
        1,
        f"{path}:1:71: nested more than 64 lists or mappings deep; robot and motion files need a "
        "few levels\n",
        "",
    )


def test_an_unknown_tag_is_blamed_not_the_number(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("robot: arm6\nspeed: !foo 1\nkeyframes:\n  - pose: home\n")
    assert problems_of(path) == [
        f"{path}:2:8: speed must be a number in 0.01..100, got '1' with the tag !foo (remove the "
        "tag: these files use none)"
    ]
