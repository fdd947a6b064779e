"""choreo.plan.report: the figures `choreo plan` prints and `--json` writes, built in the library
from the compiled motion."""

from __future__ import annotations

import json

from cli_helpers import WAVE, motion_file

from choreo.motion.motion_file import load_motion
from choreo.plan.pipeline import compile_motion
from choreo.plan.report import plan_report


def report_of(path, **options):
    motion = load_motion(path)
    return plan_report(motion, compile_motion(motion, **options), options.get("speed") or 1.0)


def test_a_joint_the_motion_never_moves_has_no_moves_and_no_speed():
    """wave.yaml moves neither base_yaw nor wrist_roll (its keyframes never name them)."""
    report = report_of(WAVE)
    joints = {j["name"]: j for j in report["joints"]}
    for still in ("base_yaw", "wrist_roll"):
        assert joints[still]["staged_moves"] == 0
        assert joints[still]["peak_velocity_deg_s"] == 0.0
    for moved in ("shoulder", "elbow", "wrist_pitch", "gripper"):
        assert joints[moved]["staged_moves"] > 0
        assert 0 < joints[moved]["peak_velocity_deg_s"] <= joints[moved]["velocity_limit_deg_s"]


def test_the_keyframes_are_reported_as_the_planner_got_them():
    report = report_of(WAVE)
    assert report["robot"] == "arm6" and report["keyframes"] == 9
    expanded = report["expanded_keyframes"]
    assert [k["where"] for k in expanded][:2] == [f"{WAVE}:7:5", f"{WAVE}:8:5"]
    assert expanded[1]["targets_deg"] == {
        "base_yaw": 0.0,
        "shoulder": 30.0,
        "elbow": -30.0,
        "wrist_pitch": -20.0,
        "wrist_roll": 0.0,
        "gripper": 45.0,
    }
    times = report["keyframe_times_s"]
    assert times == sorted(times) and times[-1] == report["duration_s"]


def test_a_stretched_keyframe_is_in_the_report_with_its_place(tmp_path):
    path = motion_file(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    report = report_of(path, stretch=True)
    (stretch,) = report["stretches"]
    assert stretch["where"] == f"{path}:5:5"
    assert round(stretch["shift_s"], 3) == 0.367  # as `choreo play --stretch` says


def test_the_report_is_plain_json():
    report = report_of(WAVE)
    assert json.loads(json.dumps(report)) == report


def test_without_keyframes_the_report_is_the_same_but_for_them():
    motion = load_motion(WAVE)
    compiled = compile_motion(motion)
    full = plan_report(motion, compiled, 1.0)
    brief = plan_report(motion, compiled, 1.0, keyframes=False)
    assert brief["expanded_keyframes"] is None and full["expanded_keyframes"]
    assert {**brief, "expanded_keyframes": full["expanded_keyframes"]} == full
