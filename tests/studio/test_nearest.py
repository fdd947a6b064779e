"""The nearest time that works for an edit that would not plan: found within NEAREST_PLANS
plans whatever the motion's length, and always a time that does plan."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from choreo.studio import trial, yaml_edit
from choreo.studio.nearest import NEAREST_PLANS, NEAREST_STEP_S, nearest_time


def swaying(count: int, step_s: float) -> str:
    """arm6 swaying its base and shoulder through a keyframe every ``step_s``, timed with t:."""
    rng = np.random.default_rng(7)
    lines = ["robot: arm6", "keyframes:", "  - pose: home"]
    for k in range(1, count + 1):
        yaw, shoulder = rng.uniform(-30, 30), rng.uniform(-20, 20)
        lines += [
            f"  - pose: {{base_yaw: {yaw:.1f}, shoulder: {shoulder:.1f}}}",
            f"    t: {k * step_s:g}",
        ]
    return "\n".join(lines) + "\n"


def adding(text: str, after: int, base_yaw: float):
    """The file with a keyframe turning the base to ``base_yaw`` added after item ``after``,
    at a time; and the line it is written on."""

    def text_at(t_s: float) -> str:
        pose = yaml_edit.pose_mapping({"base_yaw": base_yaw})
        return yaml_edit.add_keyframe(text, after, "pose", pose, {"t": yaml_edit.number(t_s, 3)})

    return text_at, yaml_edit.keyframe_items(text_at(0.0))[after + 1].content_line + 1


def test_a_keyframe_too_near_the_next_is_bisected_to_the_nearest_time_that_works(tmp_path):
    path = tmp_path / "sway.yaml"
    text = swaying(10, 2.0)
    path.write_text(text)
    text_at, line = adding(text, 2, -90.0)  # between 4 s and 6 s: too near the one at 6 s
    assert not trial.plans(path, text_at(5.9))
    search = nearest_time(path, text_at(5.9), 5.9, text_at, (4.0, 6.0), line)
    grid = [round(4.0 + k * NEAREST_STEP_S, 6) for k in range(1, 40)]
    working = [t for t in grid if trial.plans(path, text_at(t))]  # every time, planned
    assert working and search.works == max(working)  # the latest that works: nearest 5.9
    assert len(grid) > NEAREST_PLANS and search.plans <= NEAREST_PLANS
    assert search.hint() == f"the nearest time that works is {search.works:.2f} s"


def test_a_refused_add_in_a_5_minute_motion_names_a_time_that_works_within_the_budget(tmp_path):
    path = tmp_path / "sway.yaml"
    text = swaying(300, 1.0)
    path.write_text(text)
    text_at, line = adding(text, 150, 90.0)  # 0.1 s after the keyframe at 150 s: too soon
    search = nearest_time(path, text_at(150.1), 150.1, text_at, (150.0, 151.0), line)
    assert search.works is not None and 150.1 < search.works < 151.0
    assert search.plans <= NEAREST_PLANS
    trial.check_plans(path, text_at(search.works))  # it plans, as the write is checked
    assert sorted(p.name for p in Path(tmp_path).iterdir()) == ["sway.yaml"]  # no trial left


def test_where_no_time_works_the_hint_says_what_was_tried(tmp_path):
    path = tmp_path / "sway.yaml"
    text = swaying(4, 0.4)
    path.write_text(text)
    text_at, line = adding(text, 1, 170.0)  # half a turn in 0.2 s and back: never
    search = nearest_time(path, text_at(0.6), 0.6, text_at, (0.4, 0.8), line)
    assert search.works is None
    assert search.hint() == "none of the 6 times tried from 0.45 to 0.75 s works"


@pytest.mark.parametrize(
    "text", ["robot: arm6\nkeyframes: [\n", "robot: arm6\nkeyframes:\n  - pose: nowhere\n"]
)
def test_a_file_that_would_not_load_does_not_plan(tmp_path, text):
    path = tmp_path / "m.yaml"
    path.write_text("robot: arm6\nkeyframes:\n  - pose: home\n")
    assert trial.plans(path, "robot: arm6\nkeyframes:\n  - pose: home\n")
    assert not trial.plans(path, text)
