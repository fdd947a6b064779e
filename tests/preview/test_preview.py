"""choreo.preview without rendering: the servo model, the simulation, the checks, the report, the
CLI's --check. Golden values come from the servo datasheet figures, hand arithmetic, MuJoCo's own
kinematics and statics, and the player's packet schedule."""

from __future__ import annotations

import dataclasses
import json
import math

import mujoco
import numpy as np
import pytest
from paths import REPO
from preview_helpers import MOTIONS, linear_ticks, tick_at

from choreo.bus.protocol import Command
from choreo.bus.servo_models import ACTUATOR_FIELDS
from choreo.errors import OptionError, PreviewError
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import Tick, compile_ticks
from choreo.play.dry_run import packet_schedule
from choreo.preview import (
    CheckKind,
    CheckThresholds,
    Severity,
    SimSettings,
    actuator_params,
    joint_summaries,
    preview_report,
    run_checks,
    simulate,
    simulate_motion,
)
from choreo.preview.actuator import (
    ActuatorParams,
    CommandStream,
    ServoBank,
    commanded_path_units,
)
from choreo.preview.findings import episodes
from choreo.preview.model import apply_servo_models, index_joints, load_model

LX16A_STALL_NM = 17 * 0.0981  # servo-models.md: 17 kg·cm
LX16A_NO_LOAD_DEG_S = 60 / 0.16  # 0.16 s/60°


def stream_of(*ticks: Tick) -> CommandStream:
    return CommandStream.from_ticks(ticks, len(ticks[0].targets_units))


# --- the servos' own moves -----------------------------------------------------------------------
def test_a_move_is_linear_from_the_start_to_the_target_in_the_time_given():
    stream = stream_of(Tick(0, 100, (600,), (True,)))
    bank = ServoBank(np.array([500.0]), max_speed_units_s=None)
    bank.start(stream, 0, 0.0, np.array([500.0]))
    assert bank.setpoint_units(0.05)[0] == pytest.approx(550)
    assert bank.setpoint_units(0.1)[0] == pytest.approx(600)
    assert bank.setpoint_units(0.3)[0] == pytest.approx(600)


def test_a_move_too_fast_for_the_motor_runs_at_its_no_load_speed():
    # 0 ms = as fast as possible: 250 units = 60° at 375°/s takes 0.16 s
    stream = stream_of(Tick(0, 0, (750,), (True,)))
    speed_units_s = np.array([LX16A_NO_LOAD_DEG_S * 1000 / 240])
    bank = ServoBank(np.array([500.0]), max_speed_units_s=speed_units_s)
    bank.start(stream, 0, 0.0, np.array([500.0]))
    assert bank.setpoint_units(0.08)[0] == pytest.approx(625)
    assert bank.setpoint_units(0.159)[0] < 750
    assert bank.setpoint_units(0.16)[0] == pytest.approx(750)


def test_a_servo_not_restaged_re_runs_its_preset_from_where_it_is():
    # servo 0 is staged (600 in 200 ms) at tick 0 only; tick 1 restages servo 1, and its START
    # re-runs servo 0's preset from 550 (half way): 50 units in 200 ms again
    stream = stream_of(
        Tick(0, 200, (600, 500), (True, True)), Tick(100, 100, (600, 700), (False, True))
    )
    bank = ServoBank(np.array([500.0, 500.0]), max_speed_units_s=None)
    bank.start(stream, 0, 0.0, np.array([500.0, 500.0]))
    bank.start(stream, 1, 0.1, bank.setpoint_units(0.1))
    assert bank.setpoint_units(0.2) == pytest.approx([575, 700])
    assert bank.setpoint_units(0.3) == pytest.approx([600, 700])


def test_the_first_tick_stages_every_servo_and_a_tick_that_stages_none_sends_no_start():
    stream = stream_of(
        Tick(0, 100, (600, 500), (True, False)),
        Tick(100, 100, (600, 500), (False, False)),
        Tick(200, 100, (600, 550), (False, True)),
    )
    assert stream.staged[0].tolist() == [True, True]
    assert stream.started.tolist() == [True, False, True]
    assert stream.end_s == pytest.approx(0.3)


def test_the_command_stream_is_what_the_player_sends(arm3):
    """Cross-check with the player's packet schedule: the same STARTs, each after the same
    staged servos."""
    motion = load_motion(MOTIONS / "fine.yaml")
    ticks = compile_ticks(plan_motion(motion).trajectory, arm3).ticks
    stream = CommandStream.from_ticks(ticks, len(arm3.joints))
    ids = [j.servo_id for j in arm3.joints]
    sent_starts, staged_ids = [], set()
    for item in packet_schedule(ticks, arm3):
        command, servo_id = item.packet[4], item.packet[2]
        if command == Command.MOVE_TIME_WAIT_WRITE:
            staged_ids.add(servo_id)
        elif command == Command.MOVE_START:
            sent_starts.append((item.time_ms, staged_ids))
            staged_ids = set()
    mine = [
        (int(round(stream.start_s[k] * 1000)), {ids[j] for j in np.flatnonzero(stream.staged[k])})
        for k in np.flatnonzero(stream.started)
    ]
    assert mine == sent_starts


def test_the_commanded_path_joins_the_tick_targets_in_straight_lines(arm3):
    ticks = linear_ticks(arm3, [0, 0, 0], [30, 0, 0], 300, 100)
    stream = CommandStream.from_ticks(ticks, 3)
    times = np.array([0.0, 0.05, 0.1, 0.25, 0.3, 0.5])
    path = commanded_path_units(stream, np.array([500.0, 500.0, 500.0]), times)
    # targets 10°, 20°, 30° = 541.7, 583.3, 625 units, rounded: 542, 583, 625
    yaw_units = [500, 521, 542, (583 + 625) / 2, 625, 625]
    assert path[:, 0] == pytest.approx(yaw_units, abs=0.01)
    assert path[:, 1] == pytest.approx([500] * 6)


@pytest.mark.parametrize(
    "ticks, message",
    [
        ([Tick(0, 100, (500, 500), (True, True))], "needs 3 targets"),
        (
            [Tick(100, 100, (500,) * 3, (True,) * 3), Tick(50, 100, (500,) * 3, (True,) * 3)],
            "time order",
        ),
        ([Tick(0, 100, (500, 1001, 500), (True,) * 3)], "outside 0..1000"),
        ([Tick(0, 30001, (500,) * 3, (True,) * 3)], "outside 0..30000"),
    ],
)
def test_bad_ticks_are_refused_saying_which(ticks, message):
    with pytest.raises(ValueError, match=message):
        CommandStream.from_ticks(ticks, 3)


# --- the actuator model ------------------------------------------------------------------------
def test_actuators_come_from_the_servo_model_and_overrides_replace_fields(arm3):
    default = actuator_params(arm3)[1]
    assert default.stall_torque_nm == pytest.approx(LX16A_STALL_NM)
    assert default.kp_nm_rad == pytest.approx(15.9, abs=0.1)  # servo-models.md: ≈ 16
    assert default.damping_nm_s_rad == pytest.approx(0.255, abs=0.001)
    weak = actuator_params(arm3, {"shoulder": {"stall_torque_nm": 0.5}})[1]
    assert weak.stall_torque_nm == 0.5 and weak.kp_nm_rad == default.kp_nm_rad
    for overrides, problem in (
        ({"knee": {"kp_nm_rad": 1}}, "names unknown joints knee; joints of arm3: yaw, shoulder, "),
        ({"elbow": {"kd": 1}}, "gives elbow the unknown field 'kd'; the fields: stall_torque_nm, "),
        ({"elbow": {"kp_nm_rad": -1}}, "gives elbow's kp_nm_rad -1; it must be a number > 0"),
        ({"elbow": {"kp_nm_rad": 10**400}}, "gives elbow's kp_nm_rad 1000000000000000000"),
        ({"elbow": {"friction_nm": math.nan}}, "gives elbow's friction_nm nan; it must be a numbe"),
        ({"elbow": 5}, "must map joint names to {field: value}, e.g. {'elbow': {'stall_torque_nm'"),
    ):
        with pytest.raises(OptionError) as refused:
            actuator_params(arm3, overrides)
        assert refused.value.option == "actuator_overrides"
        assert refused.value.problem.startswith(problem)


def test_the_compiled_model_gets_the_servo_model_whatever_the_mjcf_says(arm3):
    model = load_model(arm3)  # the MJCF says kp 16, damping 0.25
    index = index_joints(model, arm3)
    apply_servo_models(model, index, actuator_params(arm3), arm3)
    for a, d in zip(index.actuator, index.dof):
        assert model.actuator_gainprm[a, 0] == pytest.approx(LX16A_STALL_NM / 0.105)
        assert model.actuator_biasprm[a, 1] == pytest.approx(-LX16A_STALL_NM / 0.105)
        assert model.actuator_forcerange[a] == pytest.approx([-LX16A_STALL_NM, LX16A_STALL_NM])
        assert model.dof_damping[d] == pytest.approx(
            LX16A_STALL_NM / math.radians(LX16A_NO_LOAD_DEG_S)
        )
        assert model.dof_armature[d] == pytest.approx(0.005)
        # the servo can aim anywhere in its 240°, so a target past a joint limit pushes on
        assert model.actuator_ctrlrange[a] == pytest.approx([-2 * math.pi / 3, 2 * math.pi / 3])


def test_a_missing_mjcf_joint_is_a_preview_error(arm3):
    import dataclasses

    joints = (dataclasses.replace(arm3.joints[0], mjcf_joint="no_such_joint"), *arm3.joints[1:])
    with pytest.raises(PreviewError, match="yaw: MJCF joint 'no_such_joint' not found"):
        index_joints(load_model(arm3), dataclasses.replace(arm3, joints=joints))


# --- the simulation ----------------------------------------------------------------------------
def test_a_90_degree_step_takes_about_as_long_as_the_datasheet_says(arm3):
    """servo-models.md: a 90° step of an LX-16A-class arm took ~260 ms, peaking near 330°/s;
    the servo cannot beat its no-load speed (90° in 0.24 s)."""
    units = tuple(int(round(j.to_units(a))) for j, a in zip(arm3.joints, (90, 0, 0)))
    rollout = simulate(arm3, [Tick(0, 0, units, (True, True, True))], [0, 0, 0])
    yaw = rollout.position_deg[:, 0]
    reached_s = rollout.times_s[np.argmax(yaw >= 89)]
    speed = np.gradient(yaw, rollout.times_s)
    assert 90 / LX16A_NO_LOAD_DEG_S <= reached_s <= 0.32
    assert 300 <= speed.max() <= LX16A_NO_LOAD_DEG_S + 0.5
    assert abs(yaw[-1] - 90) < 0.5  # and it settles on the target


def test_holding_a_pose_stays_there_with_little_torque(arm3):
    rollout = simulate(arm3, linear_ticks(arm3, [0, 30, 30], [0, 30, 30], 500, 100), [0, 30, 30])
    assert np.abs(rollout.position_deg - [0, 30, 30]).max() < 1.0
    assert np.abs(rollout.torque_nm).max() < 0.3 * LX16A_STALL_NM
    assert rollout.times_s[-1] == pytest.approx(0.5 + SimSettings().tail_s)


def first_overload_s(robot, trajectory, joint: str) -> float:
    """When following the plan first needs more than the stall torque at ``joint``: MuJoCo's
    inverse dynamics along the plan, with the datasheet's damping and armature."""
    model = mujoco.MjModel.from_xml_path(str(robot.scene_path))
    model.dof_damping[:] = LX16A_STALL_NM / math.radians(LX16A_NO_LOAD_DEG_S)
    model.dof_armature[:] = 0.005
    data = mujoco.MjData(model)
    j = robot.joint_names.index(joint)
    times = np.arange(0.0, trajectory.duration_s, 0.002)
    for t, q, v, a in zip(times, *trajectory.sample(times)):
        data.qpos[:], data.qvel[:], data.qacc[:] = np.radians(q), np.radians(v), np.radians(a)
        mujoco.mj_inverse(model, data)
        if abs(data.qfrc_inverse[j]) >= LX16A_STALL_NM:
            return float(t)
    raise AssertionError(f"the plan never overloads {joint}")


@pytest.mark.parametrize("name", ["too_heavy.yaml", "too_fast.yaml"])
def test_a_stall_is_caught_at_the_shoulder_within_a_tick_of_the_overload(name):
    motion = load_motion(MOTIONS / name)
    trajectory = plan_motion(motion).trajectory
    ticks = compile_ticks(trajectory, motion.robot).ticks
    expected_s = first_overload_s(motion.robot, trajectory, "shoulder")
    simulated = simulate_motion(motion, start_pose="first")  # at rest in the first pose
    stalls = [r for r in run_checks(simulated) if r.kind is CheckKind.SATURATION]
    assert stalls and stalls[0].joint == "shoulder" and stalls[0].severity is Severity.ERROR
    assert abs(stalls[0].time_s - expected_s) <= tick_at(ticks, expected_s).duration_ms / 1000
    assert stalls[0].duration_s >= CheckThresholds().stall_after_s
    assert f"for {stalls[0].duration_s:.2f} s" in stalls[0].message


def test_the_same_swing_slowly_does_not_stall():
    simulated = simulate_motion(load_motion(MOTIONS / "slow_swing.yaml"), start_pose="first")
    results = run_checks(simulated)
    assert not [r for r in results if r.severity is Severity.ERROR]
    # turning round at 25° with the payload out is close to the servo's limit: a near miss
    assert {r.kind for r in results} <= {CheckKind.NEAR_MISS}


def test_a_weaker_servo_given_as_an_override_stalls_where_the_default_does_not(arm3):
    ticks = linear_ticks(arm3, [0, 0, 0], [0, 80, 0], 800, 100)
    weak = SimSettings(actuator_overrides={"shoulder": {"stall_torque_nm": 0.1}})
    assert run_checks(simulate(arm3, ticks, [0, 0, 0])) == []
    stalls = [
        r
        for r in run_checks(simulate(arm3, ticks, [0, 0, 0], settings=weak))
        if r.kind is CheckKind.SATURATION
    ]
    assert [r.joint for r in stalls] == ["shoulder"]
    assert "0.10 N·m" in stalls[0].message


def test_a_move_past_a_joint_limit_is_caught_when_the_joint_reaches_it(arm3):
    # yaw 0 -> 100° in 1 s; its limit is 90°, which the command passes at 0.9 s
    ticks = linear_ticks(arm3, [0, 0, 0], [100, 0, 0], 1000, 100)
    results = run_checks(simulate(arm3, ticks, [0, 0, 0]))
    limits = [r for r in results if r.kind is CheckKind.JOINT_LIMIT]
    assert [(r.joint, r.severity) for r in limits] == [("yaw", Severity.ERROR)]
    assert abs(limits[0].time_s - 0.9) <= 0.1
    assert limits[0].value == pytest.approx(100, abs=0.2)  # where the servo kept pushing
    assert "max limit 90°" in limits[0].message


def test_a_hexapod_tipping_over_is_a_fall(hexapod):
    home = np.array(hexapod.pose_vector("home"))
    tipped = home.copy()
    for joint, angle in [("femur", 90), ("tibia", 60)]:
        for leg in ("lf", "lm", "lr"):  # left legs up ...
            tipped[hexapod.joint_names.index(f"{leg}_{joint}")] = angle
    for leg in ("rf", "rm", "rr"):  # ... right legs pushing the body over
        tipped[hexapod.joint_names.index(f"{leg}_femur")] = -50
    rollout = simulate(hexapod, linear_ticks(hexapod, home, tipped, 500, 50), home)
    falls = [r for r in run_checks(rollout) if r.kind is CheckKind.FALL]
    tilts = [r for r in falls if r.bodies == ("torso",)]
    assert len(tilts) == 1 and tilts[0].value > 30 and 0 < tilts[0].time_s < 0.6
    # the legs that left the floor come down on it with their coxas before the body tilts 30°
    assert {r.bodies[0] for r in falls} - {"torso"} <= {"lf_coxa", "lm_coxa", "lr_coxa"}
    relaxed = CheckThresholds(fall_tilt_deg=60)
    assert not [r for r in run_checks(rollout, relaxed) if r.bodies == ("torso",)]


def test_lag_is_a_warning_and_lasting_tracking_error_an_error(arm3):
    # the command jumps 60° at once: the servo needs ~0.2 s to follow (a warning); then it is
    # asked for 110° which it cannot reach (yaw stops at its 90° limit: an error)
    units = [
        tuple(int(round(j.to_units(a))) for j, a in zip(arm3.joints, angles))
        for angles in ((60, 0, 0), (110, 0, 0))
    ]
    ticks = [Tick(0, 0, units[0], (True,) * 3), Tick(1000, 0, units[1], (True, False, False))]
    rollout = simulate(arm3, ticks, [0, 0, 0], settings=SimSettings(tail_s=1.0))
    tracking = [r for r in run_checks(rollout) if r.kind is CheckKind.TRACKING_ERROR]
    assert [(r.severity, r.time_s < 0.01) for r in tracking] == [
        (Severity.WARNING, True),
        (Severity.ERROR, False),
    ]
    assert tracking[1].value == pytest.approx(110 - 60, abs=0.5)  # the jump itself
    assert rollout.position_deg[-1, 0] == pytest.approx(90, abs=0.5)  # stuck at the limit


def test_episodes_merge_short_gaps():
    mask = np.array([0, 1, 1, 0, 1, 0, 0, 0, 1, 1], dtype=bool)
    assert episodes(mask, merge_gap_steps=1) == [(1, 5), (8, 10)]
    assert episodes(mask, merge_gap_steps=0) == [(1, 3), (4, 5), (8, 10)]
    assert episodes(np.zeros(4, dtype=bool), 3) == []


# --- the report --------------------------------------------------------------------------------
def test_the_report_has_every_result_and_each_joints_peaks():
    simulated = simulate_motion(load_motion(MOTIONS / "floor.yaml"))
    rollout = simulated.rollout
    results = run_checks(simulated)
    report = json.loads(json.dumps(preview_report(simulated, results, motion="floor")))
    assert report["ok"] is False and report["errors"] == len(results)
    assert [c["kind"] for c in report["checks"]] == [r.kind.value for r in results]
    shoulder = report["joints"][1]
    assert shoulder["joint"] == "shoulder"
    error = np.abs(rollout.position_deg[:, 1] - rollout.command_deg[:, 1])
    assert shoulder["max_tracking_error_deg"] == pytest.approx(error.max(), abs=1e-3)
    assert shoulder["peak_torque_nm"] == pytest.approx(LX16A_STALL_NM, abs=1e-3)  # it stalls
    assert [s.joint for s in joint_summaries(rollout)] == ["yaw", "shoulder", "elbow"]


def test_no_ticks_means_holding_the_first_pose(arm3):
    """A one-keyframe motion compiles to no ticks at all."""
    rollout = simulate(arm3, [], [10, 20, 30])
    assert rollout.commands_end_s == 0
    assert rollout.duration_s == pytest.approx(SimSettings().tail_s)
    assert np.abs(rollout.position_deg - [10, 20, 30]).max() < 1.0
    assert np.abs(rollout.command_deg - [10, 20, 30]).max() < 1e-9


def test_the_robot_files_actuator_block_overrides_the_servo_model(arm3):
    assert set(ACTUATOR_FIELDS) <= {f.name for f in dataclasses.fields(ActuatorParams)}
    shoulder = dataclasses.replace(arm3.joint("shoulder"), actuator={"stall_torque_nm": 0.1})
    weak_robot = dataclasses.replace(
        arm3, joints=tuple(shoulder if j.name == "shoulder" else j for j in arm3.joints)
    )
    assert actuator_params(weak_robot)[1].stall_torque_nm == 0.1
    # the run-time override still wins over the file
    assert (
        actuator_params(weak_robot, {"shoulder": {"stall_torque_nm": 0.7}})[1].stall_torque_nm
        == 0.7
    )
    ticks = linear_ticks(arm3, [0, 0, 0], [0, 80, 0], 800, 100)
    stalls = [
        r
        for r in run_checks(simulate(weak_robot, ticks, [0, 0, 0]))
        if r.kind is CheckKind.SATURATION
    ]
    assert [r.joint for r in stalls] == ["shoulder"]


PREVIEW_MOTIONS = REPO / "tests" / "data" / "preview" / "motions"
