"""Motion files: flattening, includes, mirroring, every class of mistake at its place; validate.

Fixtures: tests/data/motions (good motions for the tiny robot) and tests/data/bad_motions (each
with one kind of mistake; parts/ holds the files they include).
"""

from __future__ import annotations

import os
import shutil
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


def timing(keyframe) -> tuple:
    return keyframe.where.line, keyframe.t_s, keyframe.after_s, keyframe.hold_s, keyframe.stop


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


def test_include_becomes_a_block_with_t_turned_into_after_delays():
    keyframes = load_motion(GOOD / "wave.yaml").keyframes
    swing = GOOD / "arm_swing.yaml"
    block = keyframes[3:6]
    assert all(k.where.path == swing for k in block)
    # arm_swing: t 1.0, t 1.5 with hold 0.2, t 2.0; the include entry gives after 0.25
    assert [timing(k) for k in block] == [
        (4, None, 0.25, 0.0, False),
        (6, None, pytest.approx(0.5), 0.2, True),
        (9, None, pytest.approx(0.3), 0.0, False),  # 2.0 - 1.5 - hold 0.2
    ]
    assert [k.targets_deg for k in block] == [(10, 100, 0), (10, 40, 0), (10, 100, 0)]


def test_mirrored_include_moves_the_partner_joints():
    keyframes = load_motion(GOOD / "wave.yaml").keyframes
    mirrored = keyframes[6:9]
    # left 100/40/100 -> right -100/-40/-100; yaw 10 -> -10; left keeps its last target 100
    assert [k.targets_deg for k in mirrored] == [
        (-10, 100, -100),
        (-10, 100, -40),
        (-10, 100, -100),
    ]
    # no timing on the include entry: the block's first t (1.0) becomes an after delay
    assert timing(mirrored[0]) == (4, None, 1.0, 0.0, False)
    assert keyframes[-1].targets_deg == (0, 0, 0) and keyframes[-1].stop is True
    assert len(keyframes) == 10


def test_include_entry_t_times_the_blocks_first_keyframe():
    keyframes = load_motion(GOOD / "timed_include.yaml").keyframes
    assert [timing(k) for k in keyframes] == [
        (4, None, None, 0.0, False),
        (4, 3.0, None, 0.0, False),  # arm_swing.yaml line 4, at the entry's t
        (6, None, pytest.approx(0.5), 0.2, True),
        (9, None, pytest.approx(0.3), 0.0, False),
        (7, 5.0, None, 0.0, False),
    ]


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


def test_t_going_backwards():
    path, message = only_problem("t_backwards.yaml")
    assert message == (
        f"{path}:6:8: t 1.5 goes backwards: the keyframe before it ({path}:3:5) "
        f"cannot be left before 2 s; t values must increase along the file"
    )


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


def test_include_cycle_names_the_chain():
    path, message = only_problem("include_cycle_a.yaml")
    b = BAD / "include_cycle_b.yaml"
    assert message == (
        f"{b}:4:14: include cycle: {path} -> {b} -> {path}; a motion cannot "
        f"include itself, directly or through others"
    )


def test_malformed_yaml_is_a_message_not_a_traceback():
    path, message = only_problem("malformed.yaml")
    assert message.startswith(f"{path}:4:4: not valid YAML: ")
    assert message.endswith("(while parsing a block collection at line 3)")


def test_empty_file():
    path, message = only_problem("empty.yaml")
    assert message == f"{path}:1:1: the file is empty; a motion needs robot and keyframes"


def test_speed_inside_an_included_file_is_refused():
    path, message = only_problem("include_speed.yaml")
    assert message == (
        f"{BAD / 'parts' / 'fast_part.yaml'}:2:1: speed is not allowed in an "
        f"included file (included at {path}:3:14): the including motion's speed "
        f"applies; remove it"
    )


def test_included_file_for_another_robot():
    path, message = only_problem("include_other_robot.yaml")
    part = BAD / "parts" / "other_robot_part.yaml"
    assert message.startswith(
        f"{part}:1:8: an included file must use the including motion's robot 'tiny'"
    )
    assert message.endswith(f"(included at {path}:3:14)")


def test_mirrored_angle_outside_the_partner_limits():
    path, message = only_problem("mirror_outside_limits.yaml")
    assert message == (
        f"{path}:5:13: mirror: the keyframe at {BAD / 'parts' / 'left_up.yaml'}:3:5 "
        f"mirrored puts right at -120°, outside its limits -110..60°"
    )


def test_included_t_after_an_untimed_keyframe_cannot_become_a_delay():
    _, message = only_problem("included_t_after_untimed.yaml")
    part = BAD / "parts" / "untimed_then_t.yaml"
    assert message == (
        f"{part}:6:8: t in an included file becomes an after delay, so the "
        f"keyframe before it ({part}:4:5) needs a t or after too; give it one, "
        f"or use after here"
    )


def test_only_the_included_t_whose_keyframe_before_is_untimed_is_refused(tmp_path):
    """A later t counts from an earlier t: its keyframe before it has a time."""
    robot = (BAD.parent / "models" / "tiny" / "robot.yaml").resolve()
    part = tmp_path / "part.yaml"
    part.write_text(
        f"robot: {robot}\nkeyframes:\n  - pose: home\n  - pose: wave\n"
        "  - pose: home\n    t: 3.0\n  - pose: wave\n    t: 4.0\n"
    )
    motion = tmp_path / "motion.yaml"
    motion.write_text(f"robot: {robot}\nkeyframes:\n  - include: part.yaml\n")
    assert problems_of(motion) == [
        f"{part}:6:8: t in an included file becomes an after delay, so the "
        f"keyframe before it ({part}:4:5) needs a t or after too; give it one, "
        f"or use after here"
    ]


def test_no_keyframes():
    path, message = only_problem("no_keyframes.yaml")
    assert message == f"{path}:2:1: keyframes: the motion has no keyframes; give at least one"


def test_include_entry_takes_no_keyframe_options():
    path, message = only_problem("include_with_hold.yaml")
    assert message == (
        f"{path}:4:5: unknown key 'hold' in an include entry (pose, hold, stop and "
        f"velocity go in the included keyframes); valid keys: include, mirror, t, "
        f"after, beat, bar"
    )


def test_mirrored_include_needs_mirror_pairs(tmp_path):
    robot_folder = tmp_path / "models" / "tiny"
    shutil.copytree(DATA / "models" / "tiny", robot_folder)
    robot_file = robot_folder / "robot.yaml"
    robot_file.write_text(robot_file.read_text().split("mirror:")[0])
    (tmp_path / "part.yaml").write_text("robot: tiny\nkeyframes:\n  - pose: wave\n")
    motion = tmp_path / "m.yaml"
    motion.write_text("robot: tiny\nkeyframes:\n  - include: part.yaml\n    mirror: true\n")
    assert problems_of(motion) == [
        f"{motion}:4:13: robot 'tiny' has no mirror pairs; add 'mirror:' to {robot_file}"
    ]


def test_missing_file(tmp_path):
    missing = tmp_path / "nothing.yaml"
    assert problems_of(missing) == [
        f"{missing}:1:1: cannot read the file: No such file or directory"
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


def test_an_include_of_a_loop_of_symbolic_links_is_one_line(tmp_path):
    (tmp_path / "a.yaml").symlink_to("b.yaml")
    (tmp_path / "b.yaml").symlink_to("a.yaml")
    path = tmp_path / "m.yaml"
    path.write_text("robot: arm6\nkeyframes:\n  - pose: home\n  - include: a.yaml\n")
    assert problems_of(path) == [
        f"{path}:4:14: include: {tmp_path / 'a.yaml'} is a loop of symbolic links, not a motion "
        "file"
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
