"""A gait too fast for the joint limits gets one message at its gait: line naming the shortest
period that works, instead of one `after >=` line per keyframe (advice a gait cannot take)."""

from __future__ import annotations

from pathlib import Path

import pytest
from paths import REPO

from choreo.errors import PlanningError
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion

ROBOT = REPO / "models" / "hexapod18" / "robot.yaml"


def gait_motion(tmp_path: Path, *gaits: str) -> Path:
    path = tmp_path / f"walk{len(list(tmp_path.iterdir()))}.yaml"
    blocks = "".join(f"  - gait: {{{gait}}}\n" for gait in gaits)
    path.write_text(
        f"robot: {ROBOT.as_posix()}\nkeyframes:\n  - pose: home\n  - pose: home\n{blocks}"
    )
    return path


def test_a_gait_too_fast_gets_one_line_with_the_shortest_period(tmp_path):
    path = gait_motion(
        tmp_path,
        "pattern: tripod, steps: 2, stride: 40, lift: 30, period: 0.5",
        "pattern: wave, steps: 2, stride: 40, lift: 30",
    )
    with pytest.raises(PlanningError) as caught:
        plan_motion(load_motion(path))
    lines = str(caught.value).splitlines()
    assert len(lines) == 2  # one per gait block, not one per keyframe
    assert lines[0].startswith(f"{path}:5:5: gait: a step every 0.5 s is faster")
    assert "shortest period that works is 1 s; give period: 1 " in lines[0]
    assert lines[1].startswith(f"{path}:6:5: gait: a step every 2 s")
    assert "after >=" not in str(caught.value)


def test_the_period_named_works_and_a_tenth_less_does_not(tmp_path):
    wave = "pattern: wave, steps: 2, stride: 40, period: {}"
    plan_motion(load_motion(gait_motion(tmp_path, wave.format(3.1))))
    with pytest.raises(PlanningError, match="shortest period that works is 3.1 s"):
        plan_motion(load_motion(gait_motion(tmp_path, wave.format(3.0))))


def test_other_keyframes_too_early_keep_their_own_advice(tmp_path):
    path = tmp_path / "quick.yaml"
    path.write_text(
        f"robot: {ROBOT.as_posix()}\nkeyframes:\n  - pose: home\n"
        "  - pose: {lf_femur: 80}\n    after: 0.05\n"
        "  - gait: {pattern: tripod, steps: 1, stride: 40, period: 0.5}\n"
    )
    with pytest.raises(PlanningError) as caught:
        plan_motion(load_motion(path))
    lines = str(caught.value).splitlines()
    assert "after >=" in lines[0] and ":4:5:" in lines[0]
    assert "shortest period" in lines[-1] and ":6:5:" in lines[-1]
