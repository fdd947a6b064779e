"""``choreo plan``: the report, JSON, plot and errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import png_size
from paths import REPO

from choreo.cli import main
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.plot import plot_size_px
from choreo.plan.ticks import compile_ticks

WAVE = REPO / "motions" / "arm6" / "wave.yaml"
SIMPLE = REPO / "tests" / "data" / "motions" / "simple.yaml"  # tiny: three joints
ARM6 = REPO / "models" / "arm6" / "robot.yaml"


def run_json(capsys, *args) -> dict:
    assert main(["plan", *map(str, args), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_report_names_the_figures_of_the_plan(capsys):
    assert main(["plan", str(WAVE)]) == 0
    out = capsys.readouterr().out
    motion = load_motion(WAVE)
    trajectory = plan_motion(motion).trajectory
    ticks = compile_ticks(trajectory, motion.robot)
    assert f"{trajectory.duration_s:.3f} s" in out
    assert f"{len(ticks.ticks)} ticks, {ticks.total_bytes} bytes" in out
    assert "peak bus use" in out and "max deviation" in out
    for joint in motion.robot.joints:
        assert joint.name in out


def test_json_report_agrees_with_the_api(capsys):
    report = run_json(capsys, WAVE)
    motion = load_motion(WAVE)
    trajectory = plan_motion(motion).trajectory
    ticks = compile_ticks(trajectory, motion.robot)
    assert report["duration_s"] == pytest.approx(trajectory.duration_s)
    assert report["ticks"] == len(ticks.ticks)
    assert report["bytes"] == ticks.total_bytes == sum(t.bytes for t in ticks.ticks)
    assert report["max_deviation_deg"] == pytest.approx(ticks.max_deviation_deg)
    assert 0 < report["peak_bus_use"] < 1
    assert report["stretches"] == []
    assert [j["name"] for j in report["joints"]] == list(motion.robot.joint_names)
    for figures, joint in zip(report["joints"], motion.robot.joints):
        assert figures["velocity_limit_deg_s"] == joint.limits.vel_deg_s
        assert figures["peak_velocity_deg_s"] <= joint.limits.vel_deg_s * (1 + 1e-6)
        assert figures["peak_acceleration_deg_s2"] <= joint.limits.acc_deg_s2 * (1 + 1e-6)
    moving = {f["name"]: f["staged_moves"] for f in report["joints"]}
    assert moving["base_yaw"] == 0 and moving["wrist_pitch"] > 10  # wave flaps the wrist only


def test_speed_and_tolerance_options(capsys):
    normal = run_json(capsys, WAVE)
    slow = run_json(capsys, WAVE, "--speed", "0.5")
    fine = run_json(capsys, WAVE, "--tolerance", "0.2")
    assert slow["speed"] == 0.5
    assert slow["duration_s"] == pytest.approx(2 * normal["duration_s"])  # every step is timed
    assert fine["tolerance_deg"] == 0.2 and fine["ticks"] > normal["ticks"]
    assert fine["max_deviation_deg"] <= 0.2 + 0.12 + 1e-9


# two robots, two heights (a row per joint); tiny's three rows, not the hexapod's 18: each row
# drawn costs 0.1 s of CPU, and the size is the same sum of rows
@pytest.mark.parametrize("motion_path", [WAVE, SIMPLE])
def test_plot_is_a_png_of_the_documented_size(tmp_path, capsys, motion_path):
    out = tmp_path / "plan.png"
    assert main(["plan", str(motion_path), "--plot", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    n_joints = len(load_motion(motion_path).robot.joints)
    assert png_size(out) == plot_size_px(n_joints)
    assert out.stat().st_size > 20_000  # curves drawn, not an empty canvas


def test_plot_must_be_png(capsys):
    with pytest.raises(SystemExit) as exited:
        main(["plan", str(WAVE), "--plot", "plan.jpg"])
    assert exited.value.code == 2
    assert "must end in .png" in capsys.readouterr().err


def write_motion(tmp_path: Path, keyframes: str) -> Path:
    path = tmp_path / "fast.yaml"
    path.write_text(f"robot: {ARM6}\nkeyframes:\n  - pose: home\n{keyframes}")
    return path


def test_infeasible_time_is_one_error_line_pointing_at_the_keyframe(tmp_path, capsys):
    path = write_motion(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.2\n")
    assert main(["plan", str(path)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"choreo: error: {path}:4:5: keyframe cannot be reached at 0.200 s")
    assert "shoulder" in err and "at the earliest" in err


def test_stretch_plans_it_and_says_by_how_much(tmp_path, capsys):
    path = write_motion(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.2\n")
    assert main(["plan", str(path), "--stretch"]) == 0
    out = capsys.readouterr().out
    assert f"{path}:4:5: stretched: reached" in out
    report = run_json(capsys, path, "--stretch")
    assert report["stretches"][0]["where"] == f"{path}:4:5"
    assert report["stretches"][0]["shift_s"] > 0
