"""A motion file's keyframes list: includes as blocks (their t values made after delays), mirrored,
and every mistake in them at its place, with the times checked to increase."""

from __future__ import annotations

import shutil

import pytest
from motion_helpers import BAD, GOOD, only_problem, problems_of
from paths import DATA

from choreo.motion.motion_file import load_motion


def timing(keyframe) -> tuple:
    return keyframe.where.line, keyframe.t_s, keyframe.after_s, keyframe.hold_s, keyframe.stop


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


def test_t_going_backwards():
    path, message = only_problem("t_backwards.yaml")
    assert message == (
        f"{path}:6:8: t 1.5 goes backwards: the keyframe before it ({path}:3:5) "
        f"cannot be left before 2 s; t values must increase along the file"
    )


def test_include_cycle_names_the_chain():
    path, message = only_problem("include_cycle_a.yaml")
    b = BAD / "include_cycle_b.yaml"
    assert message == (
        f"{b}:4:14: include cycle: {path} -> {b} -> {path}; a motion cannot "
        f"include itself, directly or through others"
    )


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


def test_an_include_of_a_loop_of_symbolic_links_is_one_line(tmp_path):
    (tmp_path / "a.yaml").symlink_to("b.yaml")
    (tmp_path / "b.yaml").symlink_to("a.yaml")
    path = tmp_path / "m.yaml"
    path.write_text("robot: arm6\nkeyframes:\n  - pose: home\n  - include: a.yaml\n")
    assert problems_of(path) == [
        f"{path}:4:14: include: {tmp_path / 'a.yaml'} is a loop of symbolic links, not a motion "
        "file"
    ]
