"""What the timeline is sent of a plan: every keyframe with the joints it changes, the lanes,
the curves, the music, and the keyframe each finding belongs to."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from choreo.motion.motion_file import load_motion
from choreo.studio.session import make_plan
from choreo.studio.timeline_state import keyframe_of, timeline_state

WAVE = Path(__file__).parent.parent / "data" / "studio" / "wave.yaml"
BEAT_S = 60 / 112  # wave.yaml dances to 112 BPM, beat 1 at t 0


def test_the_state_holds_every_keyframe_with_the_joints_it_changes_and_the_music():
    plan = make_plan(load_motion(WAVE))
    state = timeline_state(plan, 3, [("base", range(6))], peaks=(0, 50, 100))
    keyframes = state["keyframes"]
    assert [k["t"] for k in keyframes] == [0.0, 1.0, 2.0, 3.0]
    assert [k["where"] for k in keyframes] == [
        "wave.yaml:6",
        "wave.yaml:8",
        "wave.yaml:10",
        "wave.yaml:14",
    ]
    # home, then shoulder and elbow, then base_yaw (the pose before is kept), then all back
    assert [k["joints"] for k in keyframes] == [[0, 1, 2, 3, 4, 5], [1, 2], [0], [0, 1, 2]]
    assert keyframes[2]["pose"]["elbow"] == 40 and all(k["editable"] for k in keyframes)
    assert state["limbs"] == [{"name": "base", "joints": [0, 1, 2, 3, 4, 5]}]
    music = state["music"]
    assert music["offset_s"] == 0.5 and music["beats_per_bar"] == 4
    assert music["beats"][:3] == pytest.approx([0, BEAT_S, 2 * BEAT_S], abs=1e-4)
    assert music["peaks"] == [0, 50, 100] and music["song_url"] == "song?v=3"
    curves = state["curves"]
    at_2s = int(np.searchsorted(curves["t"], 2.0))
    assert curves["plan"][0][at_2s] == pytest.approx(30, abs=0.5)  # base_yaw at keyframe 3
    assert curves["plan"][2][at_2s] == pytest.approx(40, abs=0.5)  # elbow
    assert curves["sim"] is None  # not simulated yet
    assert len(curves["t"]) <= 2000
    json.dumps(state)  # all of it goes to the page as JSON


def test_a_finding_belongs_to_the_keyframe_the_motion_is_moving_to():
    times = (0.0, 1.5, 3.0)
    assert [keyframe_of(times, t) for t in (0.0, 0.2, 1.5, 1.6, 2.99, 3.0, 9.0)] == [
        0,
        1,
        1,
        2,
        2,
        2,
        2,
    ]
