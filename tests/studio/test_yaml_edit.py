"""Round-trip edits of a keyframe's lines: what is already written keeps its text, what changes
keeps its place and its comment, and nothing else moves."""

from __future__ import annotations

import pytest

from choreo.studio.yaml_edit import (
    EditRefused,
    add_keyframe,
    keyframe_items,
    pose_mapping,
    retime_keyframe,
    update_pose,
    update_site,
)

MUSIC = """\
robot: arm6
keyframes:
  - pose: home
    beat: 1
  - pose: {shoulder: 20, elbow: 40}  # lean
    bar: 5   # the chorus
    beat: 3
    stop: true
"""


def test_a_retime_to_the_time_written_changes_no_byte():
    assert retime_keyframe(MUSIC, 1, "here", {"bar": 5, "beat": 3}) == MUSIC


def test_a_retime_changes_only_the_values_that_differ_and_keeps_their_comments():
    assert retime_keyframe(MUSIC, 1, "here", {"bar": 6, "beat": 3}) == MUSIC.replace(
        "bar: 5   # the chorus", "bar: 6   # the chorus"
    )
    # to a whole bar: the beat goes; in another notation: it takes the first key's place
    assert retime_keyframe(MUSIC, 1, "here", {"bar": 5}) == MUSIC.replace("    beat: 3\n", "")
    assert retime_keyframe(MUSIC, 1, "here", {"after": 0.25}) == MUSIC.replace(
        "    bar: 5   # the chorus\n    beat: 3\n", "    after: 0.25   # the chorus\n"
    )
    untimed = "robot: arm6\nkeyframes:\n  - pose: home\n    stop: true\n"
    assert retime_keyframe(untimed, 0, "here", {"bar": 2, "beat": 2}) == (
        "robot: arm6\nkeyframes:\n  - pose: home\n    stop: true\n    bar: 2\n    beat: 2\n"
    )


def test_a_pose_update_keeps_the_joints_written_and_adds_the_ones_that_changed():
    new = update_pose(MUSIC, 1, "here", {"elbow": 35.04, "gripper": 10}, {})
    assert new == MUSIC.replace(
        "{shoulder: 20, elbow: 40}  # lean", "{shoulder: 20, elbow: 35, gripper: 10}  # lean"
    )
    whole = {"base_yaw": 0, "shoulder": 0, "elbow": 0}
    assert update_pose(MUSIC, 0, "here", {"elbow": -5}, whole) == MUSIC.replace(
        "  - pose: home\n", "  - pose: {base_yaw: 0, shoulder: 0, elbow: -5}\n"
    )


def test_a_site_moves_and_keeps_its_frame_pitch_and_the_other_sites():
    text = (
        "robot: tonypi\nkeyframes:\n  - pose: home\n"
        "  - sites:\n      left_hand: {at: [1, 2, 3], frame: world}\n"
        "      right_hand: {at: [4, 5, 6], pitch: -10}\n    t: 1\n"
    )
    assert update_site(text, 1, "here", "right_hand", [7, 8.04, 9]) == text.replace(
        "[4, 5, 6]", "[7, 8, 9]"
    )


def test_a_new_keyframe_has_no_trailing_spaces_where_its_pose_wraps():
    pose = {f"joint_{i}": -10.5 for i in range(12)}
    new = add_keyframe(MUSIC, 0, "pose", pose_mapping(pose), {"after": 0.5})
    lines = new.splitlines()
    added = lines[4 : lines.index("    after: 0.5")]  # the new pose, however ruamel wraps it
    assert len(added) >= 2 and all(line == line.rstrip() for line in added)
    assert new.startswith(MUSIC.splitlines(keepends=True)[0])


def test_a_file_with_windows_line_endings_keeps_them():
    windows = MUSIC.replace("\n", "\r\n")
    assert retime_keyframe(windows, 1, "here", {"bar": 6, "beat": 3}) == MUSIC.replace(
        "bar: 5   # the chorus", "bar: 6   # the chorus"
    ).replace("\n", "\r\n")


def test_a_file_that_is_not_yaml_refuses_an_edit_in_one_line_that_says_where():
    with pytest.raises(EditRefused) as refused:
        keyframe_items("robot: arm6\nkeyframes:\n  - pose: [1, 2\n")
    message = str(refused.value)
    assert message.startswith("the file is not valid YAML at 4:1: ")  # then PyYAML's words
    assert "\n" not in message and "<unicode string>" not in message
