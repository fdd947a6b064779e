"""The studio's edits, through the studio as the page calls it (no browser): a write that would
not load or plan is refused with the file byte for byte as it was, a keyframe is found again on
every reload, other keyframes keep their time, and a write changes only what it must.

Each test edits a copy of a motion of motions/ in tmp_path, as an animator would; the tests on
arm6's wave share one studio, and those on its dance another, given to each as a new one on the
file as shipped (``as_new``)."""

from __future__ import annotations

import numpy as np
import pytest
from studio_helpers import WAVE, body_sway_rise, refused, shared_studio, studio_on, times

from choreo.robot.kinematics import Kinematics

_wave, studio = shared_studio("arm6/wave.yaml", "studio")
_dance, dance = shared_studio("arm6/dance.yaml", "dance")


def test_an_edit_is_refused_while_the_page_shows_a_plan_older_than_the_file(studio):
    path = studio.session.motion_path
    # saved in a text editor: a keyframe at 1.2 s that the elbow cannot reach in time
    broken = WAVE.replace("  # each flap", "  - pose: {elbow: -10}\n    t: 1.2\n  # each flap", 1)
    path.write_text(broken)
    studio.reload()
    assert "cannot be reached at 1.200 s" in studio.session.problems[0]
    assert studio.session.plan is not None  # the last good plan stays on screen
    studio.select_keyframe(3)  # "4 · t 1.80 s · :14" of the plan shown
    studio.move_joint("wrist_roll", 10)
    for edit in (studio.update_keyframe, studio.retime_keyframe, studio.delete_keyframe):
        edit()
        assert refused(studio) == (
            "⛔ nothing written: the page shows the last plan that worked, older than "
            f"{path} as saved, which does not load or plan: fix the file (or Undo) first"
        )
        assert path.read_text() == broken

    path.write_text(WAVE)  # fixed: the plan is the file's again, and edits hit the right line
    studio.reload()
    studio.select_keyframe(3)
    studio.move_joint("wrist_roll", 10)
    studio.update_keyframe()
    assert path.read_text() == WAVE.replace(
        "  - pose: {elbow: -36, wrist_pitch: -25}\n    after: 0.4\n  - pose: {elbow: -22",
        "  - pose: {elbow: -36, wrist_pitch: -25, wrist_roll: 10}\n    after: 0.4\n"
        "  - pose: {elbow: -22",
        1,
    )


def test_the_selected_keyframe_is_found_again_after_a_save_moved_its_line(studio):
    path = studio.session.motion_path
    studio.select_keyframe(3)  # line 14: {elbow: -36, wrist_pitch: -25}, the first such
    # another editor adds a keyframe before it, and a copy of it after it
    path.write_text(
        WAVE.replace("    stop: true\n", "    stop: true\n  - pose: {gripper: 40}\n", 1)
    )
    studio.reload()
    plan = studio.session.plan
    assert plan is not None and len(plan.motion.keyframes) == 10
    assert studio.selected == 4
    assert plan.motion.keyframes[4].where.line == 15
    assert studio.page.keyframe.value.startswith("5 · ")
    studio.move_joint("base_yaw", 5)
    studio.update_keyframe()
    assert "{elbow: -36, wrist_pitch: -25, base_yaw: 5}" in path.read_text().splitlines()[14]


def test_a_write_that_would_not_plan_is_refused_with_the_nearest_time_that_works(studio):
    path = studio.session.motion_path
    studio.select_keyframe(4)  # keyframe 5, at 2.2 s, to 2.1 s: too soon after keyframe 4
    studio.scrub(2.1)
    studio.retime_keyframe()
    line = refused(studio)
    assert line.startswith(
        f"⛔ nothing written: at 2.10 s it would not plan: {path}:16:5: keyframe cannot be "
        "reached at 2.100 s"
    )
    assert line.endswith("; the nearest time that works is 2.20 s")
    assert path.read_text() == WAVE

    studio.scrub(1.2)  # the elbow from -30 to -10 between 1.0 and 1.4 s: no time works
    studio.move_joint("elbow", -10)
    studio.add_keyframe()
    assert refused(studio).endswith("; none of the 6 times tried from 1.05 to 1.35 s works")
    assert path.read_text() == WAVE
    assert sorted(p.name for p in path.parent.iterdir()) == ["wave.yaml"]  # no trial left


def test_a_dance_keyframe_that_would_not_plan_names_the_beat_that_works(dance):
    studio = dance
    path = studio.session.motion_path
    before = path.read_bytes()
    studio.scrub(10.8)
    studio.move_joint("shoulder", 80)
    studio.move_joint("elbow", -100)
    studio.add_keyframe()
    line = refused(studio)
    assert "use bar 6 beat 2 or later (t 11.250)" in line
    assert line.endswith("the nearest time that works is 11.25 s")
    assert path.read_bytes() == before


def test_adding_in_an_after_chain_keeps_every_other_keyframe_in_time(studio):
    path = studio.session.motion_path
    kept = times(studio)
    assert studio.session.plan.end_s == pytest.approx(5.4)
    studio.scrub(4.4)  # between keyframe 8 (3.4 s, held 0.3 s) and 9 (after 1.2: 4.9 s)
    studio.take_pose("home")
    studio.move_joint("shoulder", 10)
    studio.add_keyframe()
    assert studio.said[-3].startswith("added a keyframe in ")
    # the joints that differ from keyframe 8 ({elbow: -30, wrist_pitch: -20}, gripper 45)
    assert path.read_text() == WAVE.replace(
        "    hold: 0.3\n  - pose: home\n    after: 1.2\n",
        "    hold: 0.3\n  - pose: {shoulder: 10, elbow: 0, wrist_pitch: 0, gripper: 0}\n"
        "    after: 0.7\n  - pose: home\n    after: 0.5\n",
    )
    assert times(studio) == kept[:8] + [4.4] + kept[8:]
    assert studio.session.plan.end_s == pytest.approx(5.4)


def test_a_body_keyframe_added_in_body_sway_keeps_its_length(tmp_path):
    # its first keyframes (the studio simulates a whole motion at each edit): one is added
    # between home and the body 20 mm up, before the sway
    with studio_on(tmp_path, "hexapod18/body_sway.yaml", body_sway_rise()) as studio:
        kept = times(studio)
        end_s = studio.session.plan.end_s
        studio.scrub(0.4)
        position, wxyz = studio.view.root_pose()
        studio.drag_body(position + np.array([0.0, 0.0, 0.01]), wxyz)
        studio.add_keyframe()
        text = studio.session.motion_path.read_text()
        assert "  - pose: home\n  - body: {z: 10}\n    after: 0.4\n  - body: {z: 20}\n" in text
        assert "  - body: {z: 20}\n    after: 0.4\n" in text
        assert times(studio) == kept[:1] + [0.4] + kept[1:]
        assert studio.session.plan.end_s == pytest.approx(end_s)


def test_moving_a_keyframe_rewrites_its_after_and_the_next_so_nothing_else_moves(studio):
    path = studio.session.motion_path
    kept = times(studio)
    studio.select_keyframe(2)  # at 1.4 s: after 0.4 behind keyframe 2 (1.0 s, a stop)
    studio.scrub(1.35)
    studio.retime_keyframe()
    assert path.read_text() == WAVE.replace(
        "  - pose: {elbow: -22, wrist_pitch: 20}\n    after: 0.4\n"
        "  - pose: {elbow: -36, wrist_pitch: -25}\n    after: 0.4\n",
        "  - pose: {elbow: -22, wrist_pitch: 20}\n    after: 0.35\n"
        "  - pose: {elbow: -36, wrist_pitch: -25}\n    after: 0.45\n",
        1,
    )
    assert times(studio) == kept[:2] + [1.35] + kept[3:]
    assert studio.selected == 2  # still the keyframe moved

    studio.scrub(2.0)  # past keyframe 4 (1.8 s): the order is the file's to change
    studio.retime_keyframe()
    assert "moves between the keyframes either side of it, 1.00 s and 1.80 s" in refused(studio)

    studio.delete_keyframe()  # keyframe 4 keeps its time: after 0.8 behind keyframe 2
    assert "  - pose: {elbow: -36, wrist_pitch: -25}\n    after: 0.8\n" in path.read_text()
    assert times(studio) == kept[:2] + kept[3:]


def test_update_writes_only_the_joints_that_changed(studio):
    path = studio.session.motion_path
    studio.select_keyframe(2)
    studio.update_keyframe()  # nothing posed: nothing to write
    assert "nothing to update" in refused(studio)
    studio.move_joint("elbow", -24)
    studio.move_joint("gripper", 45.04)  # 45 as written before: no change
    studio.update_keyframe()
    assert path.read_text() == WAVE.replace(
        "{elbow: -22, wrist_pitch: 20}", "{elbow: -24, wrist_pitch: 20}", 1
    )

    studio.select_keyframe(0)  # a named pose: every joint, with the one that changed
    studio.move_joint("gripper", 10)
    studio.update_keyframe()
    assert path.read_text().splitlines()[6] == (
        "  - pose: {base_yaw: 0, shoulder: 0, elbow: 0, wrist_pitch: 0, wrist_roll: 0, gripper: 10}"
    )


def test_a_no_op_move_keeps_bar_and_beat_and_writes_nothing(dance):
    studio = dance
    path = studio.session.motion_path
    before = path.read_bytes()
    studio.select_keyframe(5)  # bar: 2, beat: 3
    studio.retime_keyframe()
    assert refused(studio) == f"⛔ nothing written: {path} says this already"
    studio.scrub(studio.time_s + 0.1)
    studio.retime_keyframe()
    assert path.read_text() == before.decode().replace(
        "    bar: 2\n    beat: 3\n", "    bar: 2\n    beat: 3.187\n", 1
    )


def test_a_site_keyframe_keeps_its_pitch(tmp_path):
    with studio_on(tmp_path, "arm6/pick_and_place.yaml") as studio:
        path = studio.session.motion_path
        before = path.read_text()
        kinematics = Kinematics(studio.session.plan.motion.robot)
        studio.select_keyframe(1)  # {tool: {at: [102.8, 122.6, 90], pitch: -70}}
        origin = kinematics.world_to_base_mm([0, 0, 0])
        axes = np.stack([kinematics.world_to_base_mm(e) - origin for e in np.eye(3) * 1000], 1)
        world_m = np.linalg.solve(axes, np.array([102.8, 122.6, 100.0]) - origin)
        studio.drag_site("tool", world_m)
        assert kinematics.site_pose("tool", studio.posing).pitch_deg == pytest.approx(-70, abs=1)
        studio.update_keyframe()
        assert path.read_text() == before.replace(
            "{tool: {at: [102.8, 122.6, 90], pitch: -70}}",
            "{tool: {at: [102.8, 122.6, 100], pitch: -70}}",
            1,
        )


def test_adding_where_a_keyframe_stands_selects_it_for_update(studio):
    path = studio.session.motion_path
    for t_s, index in ((1.4, 2), (0.0, 0)):
        studio.scrub(t_s)
        studio.move_joint("gripper", 30)
        studio.add_keyframe()
        assert refused(studio) == (
            f"⛔ nothing written: keyframe {index + 1} ({path}:{(7, 12)[index > 0]}:5) "
            f"stands at {t_s:.2f} s: selected it: Update writes the pose into it"
        )
        assert studio.selected == index and studio.posing is not None
    studio.update_keyframe()
    assert path.read_text().splitlines()[6].endswith("gripper: 30}")


def test_undo_and_redo_restore_the_file_byte_for_byte_and_never_an_outside_edit(studio):
    path = studio.session.motion_path
    original = path.read_bytes()
    studio.undo()
    assert refused(studio) == "⛔ nothing to undo: the page has written nothing yet"
    studio.scrub(4.4)
    studio.add_keyframe()
    added = path.read_bytes()
    studio.select_keyframe(2)
    studio.move_joint("elbow", -24)
    studio.update_keyframe()
    updated = path.read_bytes()
    assert len({original, added, updated}) == 3

    studio.undo()
    assert path.read_bytes() == added
    studio.undo()
    assert path.read_bytes() == original
    assert times(studio)[-1] == pytest.approx(4.9)  # the page shows the file undone
    studio.redo()
    assert path.read_bytes() == added
    assert len(times(studio)) == 10

    path.write_bytes(added + b"# a comment from the text editor\n")
    studio.undo()
    assert refused(studio) == (
        f"⛔ cannot undo added a keyframe: {path} changed on disk since the studio wrote it; "
        "the outside edit stays (undo it in the editor that made it)"
    )
    assert path.read_bytes() == added + b"# a comment from the text editor\n"
