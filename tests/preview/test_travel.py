"""The issue's acceptance in the preview (MuJoCo physics, servos that lag and have a torque
limit): the shipped gaits travel and turn as asked without a fall, body poses keep the feet
planted, and pick_and_place's tool goes down onto the block and lifts straight up."""

from __future__ import annotations

import functools
import json

import mujoco
import numpy as np
import paths
import pytest
from paths import REPO
from shipped_helpers import SHIPPED_MOTIONS, loaded_shipped, simulated_shipped

from choreo.cli import main
from choreo.motion.motion_file import load_motion
from choreo.preview import (
    Severity,
    SimSettings,
    SimulatedMotion,
    body_travel,
    run_checks,
    simulate_motion,
)
from choreo.preview.model import load_model

HEXAPOD = REPO / "motions" / "hexapod18"
DATA = paths.DATA / "spatial"


def site_path_mm(rollout, motion, site: str, every: int = 5) -> np.ndarray:
    """(samples, 3) world positions of a site along the rollout from its start (after
    settling), by MuJoCo kinematics."""
    model = load_model(motion.robot, motion.props)
    data = mujoco.MjData(model)
    site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    points = []
    for qpos in rollout.since_start().qpos[::every]:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        points.append(data.site_xpos[site_id] * 1000)
    return np.array(points)


def walked(name: str, *, ideal: bool = False):
    """Where the shipped hexapod motion ``name`` took the body, and its errors; ``ideal``: with
    ideal servos. Each simulated once in the process (two tests ask for the ideal turn; with the
    default servos, shipped_helpers shares the simulations test_preview_shipped.py checks)."""
    simulated = (
        _ideal_servos_simulated(name) if ideal else simulated_shipped(HEXAPOD / f"{name}.yaml")
    )
    errors = [r for r in run_checks(simulated) if r.severity is Severity.ERROR]
    return simulated.travel, errors


@functools.cache
def _ideal_servos_simulated(name: str) -> SimulatedMotion:
    return simulate_motion(loaded_shipped(HEXAPOD / f"{name}.yaml"), ideal_servos(name))


def ideal_servos(name: str) -> SimSettings:
    """No dead band and no backlash: the gait's own geometry, without the servo model's assumed
    play (docs/servo-models.md)."""
    robot = loaded_shipped(HEXAPOD / f"{name}.yaml").robot
    ideal = {"deadband_deg": 0.0, "backlash_deg": 0.0}
    return SimSettings(actuator_overrides={joint.name: ideal for joint in robot.joints})


def test_six_tripod_steps_of_40_mm_travel_240_mm():
    travel, errors = walked("walk_forward")
    assert errors == []  # no fall, no stall, no collision
    assert 240 * 0.85 <= travel.displacement_mm <= 240 * 1.15
    assert abs(travel.end_mm[1] - travel.start_mm[1]) < 0.15 * 240  # straight ahead
    assert abs(travel.turned_deg) < 5


def test_turning_in_place_turns_the_asked_angle():
    travel, errors = walked("turn_in_place", ideal=True)
    assert errors == []
    assert 60 * 0.85 <= travel.turned_deg <= 60 * 1.15
    assert travel.displacement_mm < 20


def test_the_servos_assumed_play_costs_part_of_the_turn():
    """With the default dead band and backlash each stance stroke loses a little: the preview
    shows a shorter turn than ideal servos make, but still most of it."""
    ideal, _ = walked("turn_in_place", ideal=True)
    real, errors = walked("turn_in_place")
    assert errors == []
    assert 60 * 0.75 <= real.turned_deg < ideal.turned_deg


def test_side_step_goes_left_then_back_right():
    travel, errors = walked("side_step")
    assert errors == []
    # 4 x 30 mm left, then 3 x 30 mm right
    assert 30 * 0.5 <= travel.end_mm[1] - travel.start_mm[1] <= 30 * 1.5
    assert travel.path_mm >= (120 + 90) * 0.85


@pytest.mark.parametrize("path", [DATA / "body_pose.yaml", HEXAPOD / "body_sway.yaml"])
def test_body_poses_keep_every_foot_where_it_was_planted(path):
    shipped = path in SHIPPED_MOTIONS
    motion = loaded_shipped(path) if shipped else load_motion(path)
    simulated = simulated_shipped(path) if shipped else simulate_motion(motion)
    rollout = simulated.rollout
    assert [r for r in run_checks(simulated) if r.severity is Severity.ERROR] == []
    travel = body_travel(rollout)
    assert travel == simulated.travel  # measured once, from the rollout
    assert travel.path_mm > 20  # the body did move
    for foot in ("lf_foot", "lm_foot", "lr_foot", "rf_foot", "rm_foot", "rr_foot"):
        feet = site_path_mm(rollout, motion, foot)
        assert np.linalg.norm(feet - feet[0], axis=1).max() <= 5.0, foot


def test_pick_and_place_grips_the_block_lifts_straight_up_and_sets_it_down_on_target():
    path = REPO / "motions" / "arm6" / "pick_and_place.yaml"
    motion, simulated = loaded_shipped(path), simulated_shipped(path)
    rollout = simulated.rollout
    assert run_checks(simulated) == []  # no collision, the block neither dropped nor misplaced
    tool = site_path_mm(rollout, motion, "tool", every=1)
    times = rollout.since_start().times_s
    at = rollout.keyframe_times_s
    block = np.array([102.8, 122.6])
    # round the block: keyframe 3, the tool 2 cm over the table. The arm sags under its own
    # weight (about 6 mm with the servo model's dead band and backlash, 3 mm without): well
    # inside the 15 mm from the block's centre to its side, so the fingers close round it.
    grasp = tool[np.searchsorted(times, at[3] + 0.3)]
    assert np.linalg.norm(grasp[:2] - block) <= 8 and abs(grasp[2] - 20) <= 8
    (outcome,) = simulated.props
    # carried: lifted with the tool (from 20 to 90 mm less the sag) and set down 245 mm away
    # (2 x 122.6 mm across), within the 10 mm place tolerance of its target
    assert outcome.lifted_m * 1000 >= 55
    assert outcome.displacement_m * 1000 == pytest.approx(245.2, abs=10)
    assert outcome.placed and outcome.place_error_m * 1000 <= 10
    assert outcome.dropped_at_s is None and not outcome.knocked_over
    # lifting (after the gripper's hold, keyframes 5 and 6): straight up, at most 5 mm aside
    lift = tool[(times >= at[4] + 0.3) & (times <= at[6])]
    assert lift[-1, 2] - lift[0, 2] >= 40
    assert np.linalg.norm(lift[:, :2] - lift[0, :2], axis=1).max() <= 5


def test_preview_reports_where_the_body_went(tmp_path, capsys):
    """turn_in_place's first two steps (20°, one per tripod): the command simulates afresh."""
    report_path = tmp_path / "report.json"
    text = (HEXAPOD / "turn_in_place.yaml").read_text().replace("steps: 6,", "steps: 2,")
    robot = REPO / "models" / "hexapod18" / "robot.yaml"
    motion = tmp_path / "turn_a_little.yaml"
    motion.write_text(text.replace("robot: hexapod18", f"robot: {robot.as_posix()}"))
    assert main(["preview", "--check", "--report", str(report_path), str(motion)]) == 0
    out = capsys.readouterr().out
    travel = json.loads(report_path.read_text())["body_travel"]
    assert travel["body"] == "torso"
    assert set(travel) == {
        "body",
        "start_mm",
        "end_mm",
        "start_heading_deg",
        "end_heading_deg",
        "turned_deg",
        "displacement_mm",
        "path_mm",
    }
    assert travel["start_heading_deg"] == 0 and travel["end_heading_deg"] == travel["turned_deg"]
    assert travel["start_mm"][2] == pytest.approx(85.9, abs=5)  # standing height
    line = f"{motion}: torso went from (0, 0) mm heading 0° to "
    assert line in out and f"turned +{round(travel['turned_deg'])}°" in out


def test_a_fixed_robot_has_no_body_travel(tmp_path):
    report_path = tmp_path / "report.json"
    motion = REPO / "motions" / "arm6" / "wave.yaml"
    assert main(["preview", "--check", "--report", str(report_path), str(motion)]) == 0
    assert json.loads(report_path.read_text())["body_travel"] is None


def test_tonypi_hands_placed_in_space_play_cleanly():
    simulated = simulate_motion(load_motion(DATA / "reach_and_clap.yaml"))
    assert run_checks(simulated) == []  # no fall, no hands through each other
