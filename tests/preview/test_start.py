"""The preview's start (as the player would start), what counts as a stall, a near miss, a fall
or an overlap, and the servo model's stated assumptions (supply, dead band, backlash).

Golden values come from outside the code under test: the MJCF authors' keyframes (where the
body stands or lies), the player's own approach plan, the servo datasheet figures, and the cases
measured in issue 11."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import paths
import pytest
from paths import REPO
from preview_helpers import linear_ticks
from shipped_helpers import simulated_shipped

from choreo.cli import main
from choreo.errors import OptionError, SourceError
from choreo.motion.motion_file import load_motion
from choreo.motion.scene import Prop, StartPosture
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.plan.ticks import Tick
from choreo.preview import (
    CheckKind,
    Severity,
    SimSettings,
    actuator_params,
    preview_report,
    run_checks,
    simulate,
    simulate_motion,
    start_lines,
)
from choreo.preview.model import load_model
from choreo.preview.start import lowest_clearance_m
from choreo.robot.robot_file import load_robot

DATA = paths.DATA / "preview"
MOTIONS = DATA / "motions"
HEXAPOD = REPO / "models" / "hexapod18"
LX16A_STALL_NM = 17 * 0.0981
LX16A_NO_LOAD_DEG_S = 60 / 0.16


def mjcf_key_height(robot, key: str) -> float:
    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    return float(model.key(key).qpos[2])


def clearance_at(rollout, step: int) -> float:
    """How far the robot's lowest geometry is above the floor at ``step`` (MuJoCo's distance)."""
    model = load_model(rollout.robot, rollout.props)
    data = mujoco.MjData(model)
    data.qpos[:] = rollout.qpos[step]
    mujoco.mj_forward(model, data)
    return lowest_clearance_m(model, data)


def kinds(results) -> set[CheckKind]:
    return {r.kind for r in results}


# --- the start ---------------------------------------------------------------------------------
def test_stand_up_starts_lying_on_the_floor_in_its_first_pose():
    path = REPO / "motions" / "hexapod18" / "stand_up.yaml"
    motion = load_motion(path)
    assert motion.start is StartPosture.LYING
    simulated = simulated_shipped(path)
    rollout = simulated.rollout
    s0 = rollout.start_step
    # it lies in its first pose already: no approach, and the body where the MJCF's lying key is
    assert rollout.approach_start_s == 0
    lying_height = mjcf_key_height(motion.robot, "lying")
    assert rollout.body.height_m[s0] == pytest.approx(lying_height, abs=0.003)
    assert abs(clearance_at(rollout, 0)) < 0.0005  # put down with its lowest geometry on the floor
    settling = rollout.settling
    assert settling.still and settling.duration_s < 1.0
    assert abs(settling.drop_m) < 0.002 and settling.tilt_deg < 1.0
    # lying at the start is not a fall; standing up is not one either
    assert run_checks(simulated) == []
    assert rollout.body.height_m[-1] == pytest.approx(
        mjcf_key_height(motion.robot, "home"), abs=0.01
    )


def test_squat_starts_standing_at_home_and_approaches_as_the_player_does():
    path = REPO / "motions" / "tonypi" / "squat.yaml"
    motion = load_motion(path)
    simulated = simulated_shipped(path)
    rollout = simulated.rollout
    home = motion.robot.pose_vector("home")
    performance = prepare(compile_motion(motion), home)
    assert rollout.approach_start_s == pytest.approx(-performance.approach_s)
    s0 = rollout.start_step
    assert rollout.position_deg[s0] == pytest.approx(home, abs=1.5)
    assert abs(clearance_at(rollout, s0)) < 0.001  # feet on the floor, not in it
    assert rollout.settling.still and abs(rollout.settling.drop_m) < 0.002
    # the commanded path in the approach is the player's plan into the squat
    approach = (rollout.times_s >= rollout.approach_start_s) & (rollout.times_s < 0)
    planned = performance.planned_deg(rollout.times_s[approach] - rollout.approach_start_s)
    assert np.abs(rollout.command_deg[approach] - planned).max() < 0.5 + 0.12 + 0.01
    # at t = 0 it is in the squat, already lower: nothing happens hidden before the motion
    at_zero = int(np.searchsorted(rollout.times_s, 0.0))
    squat = motion.robot.pose_vector("squat")
    assert rollout.position_deg[at_zero] == pytest.approx(squat, abs=3.0)
    assert rollout.body.height_m[at_zero] < rollout.body.height_m[s0] - 0.02
    assert rollout.phase(rollout.approach_start_s - 0.01) == "settling"
    assert rollout.phase(-0.01) == "approach" and rollout.phase(0.0) == "motion"
    assert run_checks(simulated) == []


@pytest.mark.parametrize(
    "path", sorted((REPO / "motions" / "tonypi").glob("*.yaml")), ids=lambda p: p.stem
)
def test_a_humanoid_starts_upright_with_its_feet_on_the_floor(path):
    rollout = simulated_shipped(path).rollout
    s0 = rollout.start_step
    assert abs(clearance_at(rollout, s0)) < 0.001
    assert rollout.body.tilt_deg[s0] < 1.0


def test_from_a_pose_or_the_first_keyframe():
    motion = load_motion(REPO / "motions" / "tonypi" / "bow.yaml")
    first = simulate_motion(motion, start_pose="first").rollout
    assert first.approach_start_s == 0
    with pytest.raises(OptionError, match="start_pose .nope.: no such pose .*home.*first"):
        simulate_motion(motion, start_pose="nope")


def test_a_robot_lying_face_down_is_turned_onto_its_front():
    motion = load_motion(REPO / "motions" / "tonypi" / "stand.yaml")
    face_down = simulate_motion(
        dataclasses.replace(motion, start=StartPosture.LYING_FRONT), start_pose="first"
    ).rollout
    s0 = face_down.start_step
    assert face_down.body.tilt_deg[s0] == pytest.approx(90, abs=5)
    assert abs(clearance_at(face_down, s0)) < 0.002
    # its face (+x of the body when standing) points down
    w, x, y, z = face_down.qpos[s0, 3:7]
    body_x_world_z = 2 * (x * z - w * y)
    assert body_x_world_z < -0.9


# --- stalls, can't keep up, near misses --------------------------------------------------------
def test_an_unloaded_servo_at_full_speed_does_not_stall():
    """Issue 11: arm6 wrist_roll rolling -100° -> 100° at its no-load 375°/s was called a
    stall. It is at its torque limit because it runs as fast as it can: a warning at most."""
    arm6 = load_robot("arm6")
    start = np.zeros(len(arm6.joints))
    end = start.copy()
    j = arm6.joint_names.index("wrist_roll")
    start[j], end[j] = -100, 100
    duration_ms = round(200 / LX16A_NO_LOAD_DEG_S * 1000)
    rollout = simulate(
        arm6, linear_ticks(arm6, start, end, duration_ms - duration_ms % 20, 20), start
    )
    results = run_checks(rollout)
    assert CheckKind.SATURATION not in kinds(results)
    assert not [r for r in results if r.severity is Severity.ERROR]
    slow = [r for r in results if r.kind is CheckKind.CANT_KEEP_UP]
    assert [r.joint for r in slow] in ([], ["wrist_roll"])
    # it really ran at (nearly) full speed
    speed = np.abs(np.gradient(rollout.position_deg[:, j], rollout.times_s)).max()
    assert speed > 0.9 * LX16A_NO_LOAD_DEG_S


def test_a_shoulder_swinging_at_its_limits_lags_but_does_not_stall():
    """Issue 11: arm6 shoulder -80° -> 80° at default limits, called a stall while the shaft
    moved at 250°/s: it can't keep up (a warning naming the lag), nothing worse."""
    sweep = load_motion(MOTIONS / "arm6_shoulder_sweep.yaml")
    results = run_checks(simulate_motion(sweep, start_pose="first"))
    assert not [r for r in results if r.severity is Severity.ERROR]
    slow = [r for r in results if r.kind is CheckKind.CANT_KEEP_UP]
    assert [r.joint for r in slow] == ["shoulder"]
    assert "lagging up to" in slow[0].message and slow[0].value > 10


@pytest.fixture(scope="module")
def payload_robots(tmp_path_factory) -> Path:
    """hexapod18 with a 2 kg and a 4 kg payload on its back (a body welded to the torso)."""
    folder = tmp_path_factory.mktemp("payload")
    for kg in (2, 4):
        name = f"hexapod_{kg}kg"
        target = folder / name
        target.mkdir()
        shutil.copy(HEXAPOD / "scene.xml", target / "scene.xml")
        (target / "robot.yaml").write_text(
            (HEXAPOD / "robot.yaml").read_text().replace("name: hexapod18", f"name: {name}")
        )
        torso = '<body name="torso" pos="0 0 0.0859" childclass="hexapod18">'
        mjcf = (HEXAPOD / "hexapod18.xml").read_text()
        assert torso in mjcf
        payload = (
            f'<body name="payload" pos="0 0 0.04"><inertial pos="0 0 0" mass="{kg}" '
            f'diaginertia="0.001 0.001 0.001"/><geom type="box" size="0.04 0.04 0.01" '
            f'class="visual"/></body>'
        )
        (target / "hexapod18.xml").write_text(mjcf.replace(torso, torso + payload))
    return folder


def test_a_genuinely_overloaded_hexapod_stalls(payload_robots):
    """4 kg on three legs: the femurs holding it are at their limit and cannot move."""
    motion = payload_robots / "tripod.yaml"
    motion.write_text(
        "robot: hexapod_4kg/robot.yaml\nkeyframes:\n  - pose: home\n"
        "  - pose: {lf_femur: 60, rm_femur: 60, lr_femur: 60}\n    after: 0.5\n    hold: 1.0\n"
    )
    results = run_checks(simulate_motion(load_motion(motion)))
    stalls = [r for r in results if r.kind is CheckKind.SATURATION]
    assert stalls and all(r.severity is Severity.ERROR for r in stalls)
    assert {r.joint for r in stalls} <= {"lm_femur", "rf_femur", "rr_femur"}  # the legs down
    assert all("barely moving" in r.message for r in stalls)


def test_standing_up_fast_with_a_payload_is_a_near_miss(payload_robots):
    """Issue 11: a 2 kg payload standing up at full speed holds the femurs at 100 % of stall
    for ~144 ms, lagging ~9.4°: a warning, per femur."""
    motion = payload_robots / "fast_stand.yaml"
    motion.write_text(
        "robot: hexapod_2kg/robot.yaml\nstart: lying\nkeyframes:\n  - pose: lying\n"
        "  - pose: home\n    hold: 0.5\n"
    )
    simulated = simulate_motion(load_motion(motion))
    results = run_checks(simulated)
    assert not [r for r in results if r.severity is Severity.ERROR]
    near = [r for r in results if r.kind is CheckKind.NEAR_MISS]
    femurs = {f"{leg}_femur" for leg in ("lf", "lm", "lr", "rf", "rm", "rr")}
    assert {r.joint for r in near} == femurs
    assert all(r.severity is Severity.WARNING and 0.1 <= r.duration_s < 0.25 for r in near)
    assert all(r.value >= 98 for r in near)  # peak % of stall
    report = preview_report(simulated, results)
    femur = next(j for j in report["joints"] if j["joint"] == "lf_femur")
    assert femur["peak_torque_pct"] >= 98 and femur["near_limit_s"] >= 0.1


# --- falls -------------------------------------------------------------------------------------
def test_the_hexapod_tipping_onto_its_side_is_caught_with_body_and_time():
    """Issue 11: three left femurs to 80° tip it over (83 -> 48 mm, a coxa on the floor,
    11.7° tilt), which the old check let through."""
    motion = load_motion(MOTIONS / "hexapod_tip.yaml")
    simulated = simulate_motion(motion)
    falls = [r for r in run_checks(simulated) if r.kind is CheckKind.FALL]
    assert falls and all(r.severity is Severity.ERROR for r in falls)
    # the raised left feet come down first (the plan has them up), then a coxa is on the floor
    assert {r.bodies[0] for r in falls[:3]} == {"lf_tibia", "lm_tibia", "lr_tibia"}
    (first,) = [r for r in falls if "collapses" in r.message]
    assert first.bodies[0] in {"lf_coxa", "lm_coxa", "lr_coxa"} and first.bodies[1] == "floor"
    assert 0 < first.time_s < 2.0
    assert f"{first.bodies[0]} touches the floor at t={first.time_s:.2f} s" in first.message
    # the body really dropped by then: MuJoCo's own record of it
    rollout = simulated.rollout
    step = int(np.searchsorted(rollout.times_s, first.time_s))
    assert rollout.body.height_m[step] < rollout.body.height_m[rollout.start_step] - 0.01


# --- contacts MuJoCo simulates between neighbours ----------------------------------------------
def test_a_base_overlapping_its_first_link_is_reported_as_the_cause(tmp_path):
    """Issue 11: a fixed base overlapping its first link was reported as the pan servo being
    too slow for its load; the real cause is the contact MuJoCo simulates between them."""
    source = DATA / "models" / "arm3"
    target = tmp_path / "arm3"
    shutil.copytree(source, target)
    mjcf = (target / "arm3.xml").read_text()
    turntable = '<geom type="cylinder" size="0.025 0.005" pos="0 0 0.005"/>'
    assert turntable in mjcf
    # the turntable disc sunk 15 mm into the column it sits on
    (target / "arm3.xml").write_text(
        mjcf.replace(turntable, turntable.replace('pos="0 0 0.005"', 'pos="0 0 -0.01"'))
    )
    robot = load_robot(target / "robot.yaml")
    ticks = linear_ticks(robot, [0, 0, 0], [80, 0, 0], 800, 40)
    results = run_checks(simulate(robot, ticks, [0, 0, 0]))
    overlaps = [r for r in results if r.kind is CheckKind.NEIGHBOUR_CONTACT]
    assert overlaps and overlaps[0].severity is Severity.ERROR
    assert set(overlaps[0].bodies) == {"base", "turntable"}
    assert "overlap from the start" in overlaps[0].message
    assert "parent and child" in overlaps[0].message
    for strained in [
        r for r in results if r.joint == "yaw" and r.kind is not CheckKind.TRACKING_ERROR
    ]:
        assert "base touches turntable" in strained.message


# --- the servo model's assumptions -------------------------------------------------------------
def test_torque_and_speed_scale_with_the_supply_and_the_file_can_say_so(tmp_path):
    target = tmp_path / "arm3"
    shutil.copytree(DATA / "models" / "arm3", target)
    text = (target / "robot.yaml").read_text()
    (target / "robot.yaml").write_text(
        text.replace("defaults:", "bus:\n  supply_v: 5.55\ndefaults:").replace(
            "elbow:    {id: 3, min: -110, max: 110}",
            "elbow:    {id: 3, min: -110, max: 110, actuator: {supply_v: 7.4, backlash_deg: 0}}",
        )
    )
    robot = load_robot(target / "robot.yaml")
    assert robot.bus.supply_v == 5.55
    yaw, _, elbow = actuator_params(robot)
    assert yaw.supply_v == 5.55 and yaw.rated_supply_v == 7.4  # LX-16A: rated at 7.4 V
    assert yaw.stall_torque_nm == pytest.approx(0.75 * LX16A_STALL_NM)
    assert yaw.no_load_speed_deg_s == pytest.approx(0.75 * LX16A_NO_LOAD_DEG_S)
    assert yaw.damping_nm_s_rad == pytest.approx(elbow.damping_nm_s_rad)  # back-EMF: unchanged
    assert elbow.stall_torque_nm == pytest.approx(LX16A_STALL_NM)
    assert elbow.backlash_deg == 0 and yaw.backlash_deg == 0.5 and yaw.deadband_deg == 0.24
    rollout = simulate(robot, [], [0, 0, 0])
    report = preview_report(rollout, [])
    assert "supply 5.55 V (rated 7.4 V)" in report["assumptions"]["summary"]
    assert "(elbow 7.4)" in report["assumptions"]["summary"]
    assert report["assumptions"]["move_start"] == "setpoint"
    # the library names its argument; the command line, its flag (the next test)
    assert report["assumptions"]["summary"].endswith("moves start from the setpoint (move_start)")
    assert start_lines(rollout)[-1].endswith("moves start from the setpoint (move_start)")


def test_a_negative_backlash_in_the_robot_file_is_refused_where_it_is_written(tmp_path):
    target = tmp_path / "arm3"
    shutil.copytree(DATA / "models" / "arm3", target)
    text = (target / "robot.yaml").read_text()
    (target / "robot.yaml").write_text(
        text.replace(
            "{id: 3, min: -110, max: 110}",
            "{id: 3, min: -110, max: 110, actuator: {backlash_deg: -1}}",
        )
    )
    with pytest.raises(SourceError, match=r"robot.yaml:\d+:\d+: .*backlash_deg must be >= 0"):
        load_robot(target / "robot.yaml")


def test_errors_smaller_than_the_dead_zone_make_no_torque():
    """The yaw joint carries no gravity load: asked to move 0.3° (inside the default dead zone
    of half the 0.24° dead band plus half the 0.5° backlash) it stays; without them it goes."""
    arm3 = load_robot(DATA / "models" / "arm3" / "robot.yaml")
    target_units = int(round(arm3.joints[0].to_units(0.3)))
    moved = arm3.joints[0].to_deg(target_units)  # 0.24° steps: 0.24°
    ticks = [Tick(0, 100, (target_units, 500, 500), (True, True, True))]
    held = simulate(arm3, ticks, [0, 0, 0])
    ideal = {"deadband_deg": 0.0, "backlash_deg": 0.0}
    free = simulate(arm3, ticks, [0, 0, 0], settings=SimSettings(actuator_overrides={"yaw": ideal}))
    assert abs(held.position_deg[-1, 0]) < 0.05
    assert np.abs(held.torque_nm[held.start_step :, 0]).max() < 1e-9
    assert free.position_deg[-1, 0] == pytest.approx(moved, abs=0.02)


# --- props -------------------------------------------------------------------------------------
def test_props_stand_in_the_scene_and_a_fixed_arm_touching_one_is_named(tmp_path):
    fine = (MOTIONS / "floor.yaml").read_text()
    assert "robot:" in fine
    motion_path = MOTIONS / "floor.yaml"
    motion = load_motion(motion_path)
    # a block right where floor.yaml's forearm reaches the floor: it now hits the block first
    block = Prop("block", (0.2, 0.2, 0.05), (0.2, 0.0, 0.0))
    clean = run_checks(simulate_motion(motion))
    blocked = run_checks(simulate_motion(dataclasses.replace(motion, props=(block,))))
    first_clean = next(r for r in clean if r.kind is CheckKind.FLOOR_CONTACT)
    hits = [r for r in blocked if r.kind is CheckKind.FLOOR_CONTACT and "block" in r.bodies]
    assert hits and hits[0].time_s < first_clean.time_s
    assert "touches the block" in hits[0].message


def test_a_prop_named_like_a_geom_of_the_scene_is_blamed_at_its_line(tmp_path, capsys):
    motion = tmp_path / "m.yaml"
    motion.write_text(
        "robot: arm6\nprops:\n  - {name: floor, size_m: [0.03, 0.03, 0.03], at_m: [0.1, 0.1, 0]}\n"
        "keyframes:\n  - pose: home\n"
    )
    assert main(["preview", "--check", str(motion)]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: {motion}:3:12: props: the name 'floor' is taken by a part of the robot "
        "or its scene (scene.xml); choose another name\n"
    )


def test_the_cli_says_how_it_started_and_what_it_assumed(capsys):
    motion = REPO / "motions" / "tonypi" / "squat.yaml"
    assert main(["preview", "--check", str(motion)]) == 0
    out = capsys.readouterr().out
    assert "start: standing on the floor; settled for" in out
    assert "approach: " in out and "as the player plays it" in out
    assert (
        f"{motion}: servo model: supply 11.1 V (rated 11.1 V), 0.24° dead band, 0.5° backlash, "
        "moves start from the setpoint (--move-start)\n"
    ) in out
    assert re.search(r"hardest-working servo: \w+ at up to \d+ % of its stall torque", out)
    assert main(["preview", "--check", str(motion), "--from", "nope"]) == 2
    assert "--from nope: tonypi has no such pose; valid: home" in capsys.readouterr().err


def test_the_cli_can_start_a_motion_lying_and_writes_the_start_to_the_report(tmp_path, capsys):
    motion = REPO / "motions" / "tonypi" / "stand.yaml"
    report = tmp_path / "report.json"
    argv = ["preview", str(motion), "--start", "lying_back", "--from", "first"]
    assert main([*argv, "--report", str(report)]) == 0
    assert "start: lying_back on the floor; settled for" in capsys.readouterr().out
    written = json.loads(report.read_text())
    assert written["start"]["posture"] == "lying_back"
    assert written["start"]["feet"] == ["left_foot", "right_foot"]
    assert written["approach_start_s"] == 0 and written["start_s"] < 0
    assert "0.5° backlash" in written["assumptions"]["summary"]
    assert written["assumptions"]["summary"].endswith("from the setpoint (--move-start)")
    assert {"peak_torque_pct", "near_limit_s", "supply_v"} <= set(written["joints"][0])
