"""choreo.plan.planner: keyframes -> a jerk-limited, time-synchronized trajectory."""

from __future__ import annotations

import dataclasses
import math
import shutil
import warnings

import numpy as np
import pytest
from cli_helpers import WAVE, error_line, motion_file, usage_error_line
from hypothesis import HealthCheck, given, settings
from paths import DATA, REPO
from plan_helpers import (
    POS_EPS,
    kf,
    make_motion,
    make_robot,
    motions,
    ruckig_rest_to_rest,
    shipped_plan,
)

from choreo.cli import main
from choreo.errors import OptionError, PlanningError
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import MAX_SEGMENT_S, plan_approach, plan_motion

VEL_EPS = 1e-6  # relative
ACC_EPS = 1e-6


def dense_times(trajectory, per_s: int = 4000):
    return np.linspace(0.0, trajectory.duration_s, max(2, int(trajectory.duration_s * per_s)))


# --- timing ------------------------------------------------------------------------------------
def test_timed_keyframes_are_reached_at_their_times_and_rest_at_stops_and_ends():
    robot = make_robot(3)
    motion = make_motion(
        robot,
        [
            kf([0, 0, 0], 1),
            kf([30, -20, 10], 2, t=0.5),
            kf([60, -10, -40], 3, t=1.0),
            kf([10, 10, 10], 4, hold=0.3),
            kf([0, 0, 0], 5, after=0.4),
        ],
    )
    trajectory = plan_motion(motion).trajectory
    times = trajectory.keyframe_times_s
    assert times[:3] == pytest.approx((0.0, 0.5, 1.0), abs=1e-9)
    assert times[4] == pytest.approx(times[3] + 0.3 + 0.4, abs=1e-9)
    for t, keyframe in zip(times, motion.keyframes):
        np.testing.assert_allclose(trajectory.at(t)[0], keyframe.targets_deg, atol=POS_EPS)
    for index in (0, 3, 4):  # start, hold, end
        np.testing.assert_allclose(trajectory.at(times[index])[1], 0, atol=1e-9)
    hold = trajectory.sample(np.linspace(times[3], times[3] + 0.3, 50))
    np.testing.assert_allclose(hold[0], np.tile([10, 10, 10], (50, 1)), atol=POS_EPS)
    assert trajectory.duration_s == pytest.approx(times[4])


def test_keyframes_are_passed_smoothly_unless_a_joint_reverses():
    robot = make_robot(2)
    motion = make_motion(robot, [kf([0, 0], 1), kf([30, 30], 2, t=0.5), kf([60, 0], 3, t=1.0)])
    trajectory = plan_motion(motion).trajectory
    _, vel, acc = trajectory.at(0.5)
    assert vel[0] == pytest.approx(60.0)  # both secants are 60°/s
    assert vel[1] == 0.0  # joint 1 turns back here
    np.testing.assert_allclose(acc, 0, atol=1e-9)


def test_stop_keyframe_comes_to_rest():
    robot = make_robot(1)
    motion = make_motion(robot, [kf([0], 1), kf([30], 2, t=0.5, stop=True), kf([60], 3, t=1.0)])
    assert plan_motion(motion).trajectory.at(0.5)[1][0] == 0.0


def test_first_keyframe_time_is_a_wait_at_the_first_pose():
    robot = make_robot(1)
    motion = make_motion(robot, [kf([20], 1, t=1.5), kf([40], 2, t=2.0)])
    trajectory = plan_motion(motion).trajectory
    assert trajectory.keyframe_times_s == pytest.approx((1.5, 2.0))
    pos = trajectory.positions(np.linspace(0, 1.5, 30))
    np.testing.assert_allclose(pos, 20.0, atol=POS_EPS)


def test_as_soon_as_possible_takes_the_minimum_time_from_rest():
    robot = make_robot(2)
    motion = make_motion(robot, [kf([0, 0], 1), kf([50, -20], 2)])
    trajectory = plan_motion(motion).trajectory
    reference = ruckig_rest_to_rest(robot, [0, 0], [50, -20])
    assert trajectory.duration_s == pytest.approx(reference.duration, rel=1e-9)


def test_velocity_scale_limits_the_segment_into_its_keyframe():
    robot = make_robot(1)
    fast = plan_motion(make_motion(robot, [kf([-80], 1), kf([80], 2)])).trajectory
    slow = plan_motion(make_motion(robot, [kf([-80], 1), kf([80], 2, velocity=0.4)])).trajectory
    assert fast.peak_velocity_deg_s()[0] == pytest.approx(300.0)
    assert slow.peak_velocity_deg_s()[0] == pytest.approx(120.0)
    assert slow.duration_s > fast.duration_s


def test_speed_divides_times_and_keeps_limits():
    robot = make_robot(2)
    keyframes = [
        kf([0, 0], 1),
        kf([20, 10], 2, t=1.0),
        kf([40, 0], 3, after=1.0, hold=0.5),
        kf([0, 0], 4, t=4.0),
    ]
    normal = plan_motion(make_motion(robot, keyframes)).trajectory
    double = plan_motion(make_motion(robot, keyframes, speed=2.0)).trajectory
    override = plan_motion(make_motion(robot, keyframes, speed=2.0), speed=1.0).trajectory
    assert normal.keyframe_times_s == pytest.approx((0.0, 1.0, 2.0, 4.0))
    assert double.keyframe_times_s == pytest.approx((0.0, 0.5, 1.0, 2.0))
    assert override.keyframe_times_s == pytest.approx(normal.keyframe_times_s)
    with pytest.raises(ValueError, match="speed"):
        plan_motion(make_motion(robot, keyframes), speed=0.0)


def test_speed_up_beyond_the_limits_is_an_error_or_a_stretch():
    robot = make_robot(1)
    motion = make_motion(robot, [kf([0], 1), kf([80], 2, t=1.0)])
    plan_motion(motion)
    with pytest.raises(PlanningError, match=r"^test_motion.yaml:2:5: .*\(at speed 10\)"):
        plan_motion(motion, speed=10.0)
    result = plan_motion(motion, speed=10.0, stretch=True)
    minimum = ruckig_rest_to_rest(robot, [0], [80]).duration
    assert result.trajectory.keyframe_times_s[1] == pytest.approx(minimum)
    assert result.stretches[0].shift_s == pytest.approx(minimum - 0.1)


def test_repeat_wraps_without_stopping_through_the_first_keyframe():
    robot = make_robot(2)
    keyframes = [kf([0, 0], 1), kf([30, 20], 2, after=0.5), kf([-30, 0], 3, after=0.8)]
    trajectory = plan_motion(make_motion(robot, keyframes, repeat=3)).trajectory
    times = trajectory.keyframe_times_s
    assert len(times) == 9
    for index, t in enumerate(times):
        np.testing.assert_allclose(
            trajectory.at(t)[0], keyframes[index % 3].targets_deg, atol=POS_EPS
        )
    # joint 0 climbs from -30 through 0 to 30 across each wrap: it passes 0 moving
    assert trajectory.at(times[3])[1][0] > 10
    assert trajectory.at(times[6])[1][0] > 10
    np.testing.assert_allclose(trajectory.at(times[-1])[1], 0, atol=1e-9)  # the end rests
    assert times[4] - times[3] == pytest.approx(0.5)


def test_repeat_keeps_t_spacing_in_every_repetition():
    robot = make_robot(1)
    keyframes = [kf([0], 1), kf([40], 2, t=1.0), kf([10], 3, t=2.0, stop=True)]
    times = plan_motion(make_motion(robot, keyframes, repeat=2)).trajectory.keyframe_times_s
    assert times[:3] == pytest.approx((0.0, 1.0, 2.0))
    assert times[4] - times[3] == pytest.approx(1.0)
    assert times[5] - times[3] == pytest.approx(2.0)


def test_repeat_with_stop_on_the_last_keyframe_rests_there():
    robot = make_robot(1)
    keyframes = [kf([0], 1), kf([40], 2, after=0.5), kf([-30], 3, after=0.8, stop=True)]
    trajectory = plan_motion(make_motion(robot, keyframes, repeat=2)).trajectory
    assert trajectory.at(trajectory.keyframe_times_s[2])[1][0] == 0.0


def test_single_keyframe_motion_is_a_rest():
    robot = make_robot(2)
    trajectory = plan_motion(make_motion(robot, [kf([10, -10], 1, hold=0.5)])).trajectory
    assert trajectory.duration_s == pytest.approx(0.5)
    np.testing.assert_allclose(trajectory.positions(np.array([0.0, 0.25, 1.0])), [[10, -10]] * 3)


# --- limits and errors -------------------------------------------------------------------------
def test_pass_through_velocity_is_lowered_instead_of_overshooting_a_limit():
    robot = make_robot(1)
    # 87° is passed on the way to the 90° limit, which is asked for too early: the stretched
    # segment from the pass-through speed at 87° would carry the joint to about 101°.
    motion = make_motion(robot, [kf([50], 1), kf([87], 2), kf([90], 3, t=0.35)])
    result = plan_motion(motion, stretch=True)
    trajectory = result.trajectory
    times = dense_times(trajectory)
    pos = trajectory.positions(times)
    assert result.stretches
    assert pos.max() <= 90 + POS_EPS
    assert np.all(np.diff(pos[:, 0]) >= -1e-9)  # between keyframes a joint never turns back


def test_too_early_keyframe_names_its_line_joint_and_earliest_time():
    robot = make_robot(3)
    motion = make_motion(robot, [kf([0, 0, 0], 1), kf([0, 0, 80], 7, t=0.2)])
    minimum = ruckig_rest_to_rest(robot, [0, 0, 0], [0, 0, 80]).duration
    with pytest.raises(PlanningError) as caught:
        plan_motion(motion)
    message = str(caught.value)
    assert message.startswith("test_motion.yaml:7:5: ")
    assert " j2 " in message
    assert f"{minimum:.3f} s at the earliest" in message
    assert f"t >= {minimum:.3f}" in message


def test_stretch_shifts_later_timed_keyframes_by_the_same_amount():
    robot = make_robot(1)
    motion = make_motion(
        robot, [kf([0], 1), kf([80], 2, t=0.2), kf([40], 3, t=1.0), kf([60], 4, after=0.3)]
    )
    result = plan_motion(motion, stretch=True)
    times = result.trajectory.keyframe_times_s
    minimum = ruckig_rest_to_rest(robot, [0], [80]).duration
    assert [s.where.line for s in result.stretches] == [2]
    shift = result.stretches[0].shift_s
    assert shift == pytest.approx(minimum - 0.2)
    assert times[1] == pytest.approx(minimum)
    assert times[2] == pytest.approx(1.0 + shift)
    assert times[3] == pytest.approx(times[2] + 0.3)


def test_keyframe_outside_the_limits_is_reported_where_it_is():
    robot = make_robot(2, span_deg=45)
    motion = make_motion(robot, [kf([0, 0], 1), kf([0, 50], 4)])
    with pytest.raises(
        PlanningError,
        match=r"test_motion.yaml:4:5: j1 = 50° is outside its "
        r"limits -45..45°",
    ):
        plan_motion(motion)
    two = make_motion(robot, [kf([0, 0], 1), kf([0, 50], 4), kf([-60, 0], 6)])
    with pytest.raises(PlanningError) as caught:
        plan_motion(two)
    assert str(caught.value).splitlines() == [
        "test_motion.yaml:4:5: j1 = 50° is outside its limits -45..45°",
        "test_motion.yaml:6:5: j0 = -60° is outside its limits -45..45°",
    ]


def test_approach_starts_anywhere_and_arrives_gently():
    robot = make_robot(2, span_deg=45)
    trajectory = plan_approach(robot, [100.0, -60.0], [10.0, 0.0])
    pos, vel, acc = trajectory.sample(dense_times(trajectory))
    np.testing.assert_allclose(pos[0], [100, -60])
    np.testing.assert_allclose(pos[-1], [10, 0], atol=POS_EPS)
    assert np.all(np.abs(vel) <= 0.3 * 300 * (1 + VEL_EPS))
    assert np.all(np.abs(acc) <= 0.3 * 3000 * (1 + ACC_EPS))
    assert np.all(np.diff(pos[:, 0]) <= 1e-9)  # moves only towards its target
    with pytest.raises(ValueError, match="outside its limits"):
        plan_approach(robot, [0, 0], [50, 0])
    with pytest.raises(ValueError, match="one angle per joint"):
        plan_approach(robot, [0, 0, 0], [0, 0])


# --- properties --------------------------------------------------------------------------------
def expected_times(motion, times):
    """Arrival times the file asks for (None: as soon as possible), given the earlier arrivals:
    t counts from the repetition's first keyframe, after from the previous one's leaving."""
    played = list(motion.keyframes) * motion.repeat
    n = len(motion.keyframes)
    origin = played[0].t_s or played[0].after_s or 0.0
    expected = [origin / motion.speed]
    for index in range(1, len(played)):
        keyframe, previous = played[index], played[index - 1]
        if index % n and keyframe.t_s is not None:
            expected.append(times[index - index % n] + (keyframe.t_s - origin) / motion.speed)
        elif keyframe.after_s is not None:
            leave = times[index - 1] + previous.hold_s / motion.speed
            expected.append(leave + keyframe.after_s / motion.speed)
        else:
            expected.append(None)
    return expected


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motions())
def test_random_motions_stay_within_every_limit_and_meet_their_times(motion):
    robot = motion.robot
    try:
        plan_motion(motion)
        feasible = True
    except PlanningError as error:
        feasible = False
        assert str(error).startswith("test_motion.yaml:")
    result = plan_motion(motion, stretch=True)
    assert feasible == (not result.stretches)
    trajectory = result.trajectory
    times = np.array(trajectory.keyframe_times_s)
    assert len(times) == len(motion.keyframes) * motion.repeat
    assert np.all(np.diff(times) >= 0)

    pos, vel, acc = trajectory.sample(dense_times(trajectory, 2000))
    limits = [j.limits for j in robot.joints]
    assert np.all(pos >= np.array([x.min_deg for x in limits]) - POS_EPS)
    assert np.all(pos <= np.array([x.max_deg for x in limits]) + POS_EPS)
    assert np.all(np.abs(vel) <= np.array([x.vel_deg_s for x in limits]) * (1 + VEL_EPS))
    assert np.all(np.abs(acc) <= np.array([x.acc_deg_s2 for x in limits]) * (1 + ACC_EPS))
    assert np.all(
        trajectory.peak_velocity_deg_s() <= np.array([x.vel_deg_s for x in limits]) * (1 + VEL_EPS)
    )

    played = list(motion.keyframes) * motion.repeat
    for t, keyframe in zip(times, played):
        np.testing.assert_allclose(trajectory.at(t)[0], keyframe.targets_deg, atol=1e-6)
    if feasible:
        for t, want in zip(times, expected_times(motion, times)):
            if want is not None:
                assert t == pytest.approx(want, abs=1e-6)


# --- the shipped motions -----------------------------------------------------------------------
SHIPPED = sorted((REPO / "motions").glob("*/*.yaml"))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_motions_plan_on_time_within_limits(path):
    motion, result = shipped_plan(path)
    trajectory = result.trajectory
    times = np.array(trajectory.keyframe_times_s)
    for t, want in zip(times, expected_times(motion, times)):
        if want is not None:
            assert t == pytest.approx(want, abs=1e-6)
    limits = [j.limits for j in motion.robot.joints]
    pos = trajectory.positions(dense_times(trajectory, 1000))
    assert np.all(pos >= np.array([x.min_deg for x in limits]) - POS_EPS)
    assert np.all(pos <= np.array([x.max_deg for x in limits]) + POS_EPS)
    assert np.all(
        trajectory.peak_velocity_deg_s() <= np.array([x.vel_deg_s for x in limits]) * (1 + VEL_EPS)
    )
    assert np.all(
        trajectory.peak_acceleration_deg_s2()
        <= np.array([x.acc_deg_s2 for x in limits]) * (1 + ACC_EPS)
    )


@pytest.mark.parametrize(
    "timing, where, seconds",
    [("after: 20000", "5:5", "20000"), ("t: 86400", "5:5", "86400")],
)
def test_a_segment_longer_than_ruckig_can_plan_is_one_line(
    tmp_path, capsys, timing, where, seconds
):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    {timing}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:{where}: keyframe reached {seconds} s after leaving the one "
        "before; at most 300 s can be planned between two keyframes: hold the one before "
        "instead (a hold may last up to 86400 s), or add keyframes in between"
    )


def test_the_slowest_speed_is_held_to_the_segment_limit_in_one_line(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 30}\n    after: 4\n")
    assert main(["plan", str(path), "--speed", "0.01"]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:5:5: keyframe reached 400 s after leaving the one before "
        "(at speed 0.01); at most 300 s can be planned between two keyframes: hold the one "
        "before instead (a hold may last up to 86400 s), or add keyframes in between"
    )


@pytest.mark.parametrize("command", [["plan"], ["preview", "--check"], ["play"]])
@pytest.mark.parametrize("speed", ["1e308", "1e-308", "0.009", "100.5"])
def test_a_speed_outside_its_range_is_refused_with_the_range(capsys, command, speed):
    line = usage_error_line(capsys, [*command, str(WAVE), "--speed", speed])
    assert line == (
        f"choreo {command[0]}: error: argument --speed: expected a number >= 0.01 and <= 100, "
        f"got {speed!r}"
    )


@pytest.mark.parametrize("speed", [0.0, 1e308, math.nan])
def test_plan_motion_refuses_a_speed_outside_its_range(speed):
    with pytest.raises(OptionError) as raised:
        plan_motion(load_motion(WAVE), speed=speed)
    assert raised.value.option == "speed"
    assert str(raised.value) == f"speed must be a number >= 0.01 and <= 100, got {speed!r}"


def test_a_long_hold_is_not_limited_by_the_segment_limit(tmp_path, capsys):
    # a second past the limit: the ticks of a longer hold cost CPU in proportion and show no more
    hold = MAX_SEGMENT_S + 1
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    after: 1\n    hold: {hold:g}\n")
    assert main(["plan", str(path)]) == 0
    assert f"{hold + 1:.1f}" in capsys.readouterr().out


def test_every_unreachable_keyframe_is_reported_at_once(tmp_path, capsys):
    path = motion_file(
        tmp_path,
        "  - pose: {shoulder: 80}\n    t: 0.1\n"
        "  - pose: {shoulder: 0}\n    t: 0.3\n"
        "  - pose: {shoulder: 80}\n    after: 0.1\n",
    )
    assert main(["plan", str(path)]) == 1
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": keyframe cannot be reached")[0] for line in lines] == [
        f"choreo: error: {path}:5:5",
        f"{path}:7:5",
        f"{path}:9:5",
    ]
    # each fix, applied alone to the keyframes before, is enough: t >= 0.467 then t >= 0.933
    assert lines[0].endswith(
        "allow 0.467 s at the earliest; use t >= 0.467, a lower speed, or stretch"
    )
    assert lines[1].endswith(
        "allow 0.933 s at the earliest; use t >= 0.933, a lower speed, or stretch"
    )
    assert lines[2].endswith("use after >= 0.467, a lower speed, or stretch")


def test_the_planner_bounds_repeat_for_motions_made_in_code():
    import dataclasses

    from choreo.errors import PlanningError
    from choreo.motion.motion_file import load_motion
    from choreo.plan.planner import plan_motion

    motion = dataclasses.replace(load_motion(WAVE), repeat=10**8)
    with pytest.raises(PlanningError, match="at most 10000 are played in one motion"):
        plan_motion(motion)


def test_a_planning_error_inside_an_include_says_through_which(tmp_path, capsys):
    (tmp_path / "part.yaml").write_text(
        "robot: arm6\nkeyframes:\n  - pose: {shoulder: 0}\n"
        "  - pose: {shoulder: 80}\n    after: 0.1\n"
    )
    main_file = motion_file(tmp_path, "  - include: part.yaml\n    after: 1.0\n", name="main.yaml")
    outer = motion_file(tmp_path, "  - include: main.yaml\n", name="outer.yaml")
    assert main(["plan", str(outer)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {tmp_path / 'part.yaml'}:4:5: keyframe (included at {main_file}:5:14, "
        f"included at {outer}:5:14) cannot be reached at 1.100 s: the velocity, acceleration "
        "and jerk limits of shoulder allow 1.467 s at the earliest; use after >= 0.467, a lower "
        "speed, or stretch"
    )


def test_times_made_in_code_are_bounded_as_the_loader_bounds_them():
    motion = load_motion(WAVE)
    huge = dataclasses.replace(motion.keyframes[1], hold_s=1e308)
    motion = dataclasses.replace(motion, keyframes=(motion.keyframes[0], huge))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow on the way
        with pytest.raises(PlanningError) as raised:
            plan_motion(motion)
    assert raised.value.problems == [f"{WAVE}:8:5: hold must be in 0..86400 s, got 1e+308"]


def test_a_move_ruckig_finds_no_trajectory_for_is_one_line_at_its_keyframe():
    robot = make_robot(2, acc=1e-300)  # numbers ruckig's numerics fail on
    motion = make_motion(robot, [kf([0, 0], 3), kf([0, 30], 4, after=1.0)])
    with pytest.raises(PlanningError) as raised:
        plan_motion(motion)
    assert raised.value.problems == [
        "test_motion.yaml:4:5: the move into keyframe could not be planned: ruckig found no "
        "trajectory for j1 from 0° to 30°, its numbers out of its range; check j1's velocity, "
        "acceleration and jerk limits in models/bot/robot.yaml and the keyframe's velocity"
    ]


def test_an_approach_ruckig_finds_no_trajectory_for_is_one_line():
    robot = make_robot(2, jerk=1e-300)
    with pytest.raises(PlanningError) as raised:
        plan_approach(robot, [0, 0], [0, 30])
    assert str(raised.value) == (
        "the approach to the first keyframe could not be planned: ruckig found no trajectory for "
        "j1 from 0° to 30°, its numbers out of its range; check j1's velocity, acceleration and "
        "jerk limits in models/bot/robot.yaml"
    )


def test_a_move_planned_longer_than_a_segment_may_last_is_one_line(tmp_path, capsys):
    """velocity: 0.01 of a 10 deg/s joint asks 400 s for 40°: the same limit as a t or after
    that far, though no time was written."""
    robot = tmp_path / "tiny" / "robot.yaml"
    shutil.copytree(DATA / "models" / "tiny", robot.parent)
    robot.write_text(robot.read_text().replace("    max: 90\n", "    max: 90\n    velocity: 10\n"))
    path = tmp_path / "m.yaml"
    path.write_text(
        "robot: tiny/robot.yaml\nkeyframes:\n  - pose: home\n"
        "  - pose: {yaw: 40}\n    velocity: 0.01\n"
    )
    assert main(["validate", "--no-physics", str(path)]) == 1
    assert capsys.readouterr().out == (
        f"{path}:4:5: keyframe takes 400.004 s to reach from the one before: the velocity limit "
        "of yaw x velocity 0.01 allows no faster; at most 300 s can be planned between two "
        "keyframes: raise its velocity, or add keyframes in between\n"
    )


def test_a_move_the_robots_own_velocity_makes_too_long_says_so():
    robot = make_robot(2, vel=0.1)
    just_in = plan_motion(make_motion(robot, [kf([0, 0], 3), kf([29.9, 0], 4)])).trajectory
    assert just_in.duration_s == pytest.approx(299.004, abs=1e-3)
    with pytest.raises(PlanningError) as raised:
        plan_motion(make_motion(robot, [kf([0, 0], 3), kf([30, 0], 4)]))
    assert raised.value.problems == [
        "test_motion.yaml:4:5: keyframe takes 300.004 s to reach from the one before: the "
        "velocity limit of j0 allows no faster; at most 300 s can be planned between two "
        "keyframes: add keyframes in between, or raise j0's velocity in models/bot/robot.yaml"
    ]
