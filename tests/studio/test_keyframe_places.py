"""Where a plan's keyframes are written in the motion file, how each one's time is written, and
which keyframes an edit moved in time."""

from __future__ import annotations

from pathlib import Path

from choreo.motion.motion_file import load_motion
from choreo.studio.keyframe_places import item_text, notation_of, others_moved, placed_keyframes
from choreo.studio.session import make_plan

# timed with after:, t: and as soon as the limits allow
MIXED = """\
robot: arm6
keyframes:
  - pose: home
  - pose: {elbow: 40}   # up
    after: 1.0
  - pose: {elbow: 0}
    t: 2.5
  - pose: {elbow: 20}
"""


def plan_of(path: Path, text: str):
    path.write_text(text)
    return make_plan(load_motion(path))


def test_each_keyframe_is_found_in_its_item_with_the_notation_of_its_time(tmp_path):
    path = tmp_path / "m.yaml"
    plan = plan_of(path, MIXED)
    placed = placed_keyframes(MIXED, plan, path)
    assert [(p.index, p.item, p.alone) for p in placed] == [(i, i, True) for i in range(4)]
    assert [p.t_s for p in placed[:3]] == [0.0, 1.0, 2.5]
    assert [notation_of(plan, p) for p in placed] == [None, "after", "t", None]
    assert item_text(MIXED, 1) == "  - pose: {elbow: 40}   # up\n    after: 1.0"


def test_an_edit_that_moved_a_keyframe_timed_as_soon_as_the_limits_allow_names_it(tmp_path):
    path = tmp_path / "m.yaml"
    before = plan_of(path, MIXED)
    after = plan_of(path, MIXED.replace("t: 2.5", "t: 3.0"))  # the last one follows it
    moved = others_moved(before, after, replaced=2, line=6)
    assert moved.startswith(f"⚠ other keyframes moved (timed as soon as the limits allow): {path}:")
    assert moved.endswith(" 0.50 s later")
    assert others_moved(before, before, replaced=None, line=None) == ""
