"""choreo.plan.ticks: a trajectory -> synchronized linear servo moves (ticks)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from paths import REPO
from plan_helpers import kf, make_motion, make_robot, motions, shipped_plan

from choreo.errors import PlanningError
from choreo.plan import ticks
from choreo.plan.planner import plan_approach, plan_motion
from choreo.plan.ticks import (
    MAX_TICK_MS,
    MOVE_BYTES,
    START_BYTES,
    Tick,
    compile_ticks,
    staging_bytes,
    wire_time_ms,
)

BAUD = 115200
QUANTIZATION_DEG = 0.12  # half a servo unit (0.24°)


def servo_path_deg(robot, trajectory, plan, times_ms):
    """What the servos do: straight lines between rounded targets, from the rounded start."""
    start = [round(j.to_units(a)) for j, a in zip(robot.joints, trajectory.at(0.0)[0])]
    bounds = [0] + [t.end_ms for t in plan.ticks]
    units = np.array([start] + [t.targets_units for t in plan.ticks], dtype=float)
    path = np.empty((len(times_ms), len(robot.joints)))
    for j, joint in enumerate(robot.joints):
        path[:, j] = np.interp(times_ms, bounds, [joint.to_deg(u) for u in units[:, j]])
    return path


def measured_deviation(robot, trajectory, plan, per_ms=4):
    times_ms = np.arange(0, plan.duration_ms * per_ms + 1) / per_ms
    smooth = trajectory.positions(times_ms / 1000)
    return float(np.abs(servo_path_deg(robot, trajectory, plan, times_ms) - smooth).max())


def check_plan(robot, trajectory, plan, tolerance_deg, margin_ms=1.5):
    ticks = plan.ticks
    assert ticks[0].start_ms == 0
    end_ms = math.ceil(round(trajectory.duration_s * 1000, 6))
    assert end_ms <= ticks[-1].end_ms <= end_ms + 1  # the lattice may round the end up
    start = [round(j.to_units(a)) for j, a in zip(robot.joints, trajectory.at(0.0)[0])]
    previous = start
    for k, tick in enumerate(ticks):
        assert 1 <= tick.duration_ms <= 30000
        assert all(0 <= u <= 1000 for u in tick.targets_units)
        assert tick.staged == tuple(a != b for a, b in zip(tick.targets_units, previous))
        staged = sum(tick.staged)
        assert tick.bytes == (10 * staged + 6 if staged else 0)
        if k + 1 < len(ticks):
            assert ticks[k + 1].start_ms == tick.end_ms
            next_wire_ms = ticks[k + 1].bytes * 10 / BAUD * 1000
            assert tick.duration_ms >= next_wire_ms + margin_ms
        previous = tick.targets_units
    assert plan.total_bytes == sum(t.bytes for t in ticks)
    deviation = measured_deviation(robot, trajectory, plan)
    assert deviation <= tolerance_deg + QUANTIZATION_DEG + 1e-3
    assert deviation <= plan.max_deviation_deg + 1e-3  # the reported figure bounds it
    assert plan.max_deviation_deg <= tolerance_deg + QUANTIZATION_DEG + 1e-9


# --- bus arithmetic: figures from docs/protocol.md ------------------------------------------------
def test_packet_sizes_and_wire_times_match_the_protocol_reference():
    assert (MOVE_BYTES, START_BYTES) == (10, 6)
    assert staging_bytes(6) == 66 and staging_bytes(0) == 0
    assert wire_time_ms(staging_bytes(6)) == pytest.approx(5.7, abs=0.05)
    assert wire_time_ms(staging_bytes(18)) == pytest.approx(16.1, abs=0.1)
    assert MAX_TICK_MS == 30000


def test_tick_bytes_count_only_staged_servos():
    tick = Tick(0, 40, (500, 510, 520), (True, False, True))
    assert tick.bytes == 26 and tick.end_ms == 40
    assert Tick(0, 40, (500, 510, 520), (False, False, False)).bytes == 0


# --- targets -----------------------------------------------------------------------------------
def test_final_targets_are_the_servo_units_of_the_last_pose():
    robot = make_robot(3)  # zero 500, directions +1, -1, +1
    trajectory = plan_motion(
        make_motion(robot, [kf([0, 0, 0], 1), kf([30, 30, -90], 2)])
    ).trajectory
    plan = compile_ticks(trajectory, robot)
    # 500 + 30 * 1000/240 = 625; direction -1: 375; -90° = -375 units
    assert plan.ticks[-1].targets_units == (625, 375, 125)
    check_plan(robot, trajectory, plan, 0.5)


def test_a_joint_that_never_moves_is_never_staged():
    robot = make_robot(3)
    trajectory = plan_motion(
        make_motion(robot, [kf([0, 10, 0], 1), kf([40, 10, -20], 2), kf([-40, 10, 20], 3)])
    ).trajectory
    plan = compile_ticks(trajectory, robot)
    assert not any(t.staged[1] for t in plan.ticks)
    assert all(t.targets_units[1] == 458 for t in plan.ticks)  # 500 - 10 * 1000/240
    assert plan.total_bytes == sum(10 * sum(t.staged) + 6 for t in plan.ticks if any(t.staged))


def test_a_long_hold_is_split_into_moves_the_servo_accepts_and_costs_nothing():
    robot = make_robot(2)
    trajectory = plan_motion(
        make_motion(robot, [kf([0, 0], 1), kf([20, 20], 2, hold=65.0), kf([0, 0], 3)])
    ).trajectory
    plan = compile_ticks(trajectory, robot)
    assert max(t.duration_ms for t in plan.ticks) == MAX_TICK_MS
    idle = [t for t in plan.ticks if t.duration_ms == MAX_TICK_MS]
    assert len(idle) >= 2 and all(t.bytes == 0 for t in idle[1:])
    check_plan(robot, trajectory, plan, 0.5)


def test_tighter_tolerance_needs_more_ticks():
    robot = make_robot(6)
    motion = make_motion(
        robot,
        [kf([0] * 6, 1), kf([60, -40, 30, 10, -70, 20], 2), kf([-50, 40, -30, 0, 70, -20], 3)],
    )
    trajectory = plan_motion(motion).trajectory
    coarse = compile_ticks(trajectory, robot, tolerance_deg=1.0)
    fine = compile_ticks(trajectory, robot, tolerance_deg=0.2)
    assert len(fine.ticks) > len(coarse.ticks)
    check_plan(robot, trajectory, coarse, 1.0)
    check_plan(robot, trajectory, fine, 0.2)


def test_an_empty_trajectory_has_no_ticks():
    robot = make_robot(2)
    trajectory = plan_motion(make_motion(robot, [kf([10, 10], 1)])).trajectory
    assert compile_ticks(trajectory, robot).ticks == ()


# --- errors ------------------------------------------------------------------------------------
def test_leaving_the_servo_range_is_an_error_not_a_clamp():
    robot = make_robot(2)
    robot = replace(robot, joints=(robot.joints[0], replace(robot.joints[1], zero_units=100.0)))
    # j1 has direction -1: +60° is 100 - 250 = -150 units
    trajectory = plan_motion(make_motion(robot, [kf([0, 0], 1), kf([0, 60], 2)])).trajectory
    with pytest.raises(
        PlanningError,
        match=r"j1 \(servo 2\) would need position -\d+ .*"
        r"outside the servo's 0..1000",
    ) as caught:
        compile_ticks(trajectory, robot)
    assert len(caught.value.problems) == 1 and str(caught.value) == caught.value.problems[0]


def test_a_tolerance_the_bus_cannot_reach_is_an_error_that_says_what_would_do():
    robot = make_robot(18, acc=60000, jerk=3_000_000, vel=300)
    trajectory = plan_motion(
        make_motion(robot, [kf([-80] * 18, 1), kf([80] * 18, 2), kf([-80] * 18, 3)])
    ).trajectory
    with pytest.raises(
        PlanningError,
        match=r"tolerance 0.1° cannot be met at the bus rate: a "
        r"tick must last at least 18 ms to stage 18 servos",
    ):
        compile_ticks(trajectory, robot, tolerance_deg=0.1)


def test_bad_arguments():
    robot = make_robot(2)
    trajectory = plan_motion(make_motion(robot, [kf([0, 0], 1), kf([10, 0], 2)])).trajectory
    with pytest.raises(ValueError, match="tolerance_deg"):
        compile_ticks(trajectory, robot, tolerance_deg=0)
    with pytest.raises(ValueError, match="joints"):
        compile_ticks(trajectory, make_robot(3))


# --- quality -----------------------------------------------------------------------------------
def fewest_ticks(trajectory, tolerance_deg, floor_ms, step_ms=1):
    """Reference: the true minimum number of ticks ending on multiples of ``step_ms``, by
    dynamic programming over every end, each chord checked at every 1 ms against the smooth
    trajectory (the trajectory rests after its end).

    The chords from every start are checked at once, up to a length that doubles until each
    start's cone (the slopes its chords may take) has closed for some joint: no longer chord
    fits then, so the chords are those checked against the whole rest of the trajectory, for
    a fifth of the CPU."""
    end = math.ceil(math.ceil(round(trajectory.duration_s * 1000, 6)) / step_ms) * step_ms
    grid = trajectory.positions(np.arange(end + 1) / 1000)
    fits = {}  # each start -> the ends of its chords that fit
    starts, length = np.arange(0, end, step_ms), 64
    while starts.size:
        d = np.arange(1, length + 1)
        slope = grid[np.minimum(starts[:, None] + d, end)] - grid[starts][:, None]
        slope /= d[:, None]  # (start, chord, joint); the chords past the end are masked below
        lo = np.maximum.accumulate(slope - tolerance_deg / d[:, None], axis=1)
        hi = np.minimum.accumulate(slope + tolerance_deg / d[:, None], axis=1)
        fit = ((lo <= slope) & (slope <= hi)).all(axis=2) & (starts[:, None] + d <= end)
        done = (lo[:, -1] > hi[:, -1]).any(axis=1) | (starts + length >= end)
        for start, row in zip(starts[done].tolist(), fit[done]):
            fits[start] = start + 1 + np.flatnonzero(row)
        starts, length = starts[~done], length * 2
    best = np.full(end + 1, np.inf)
    best[0] = 0
    for start in range(0, end, step_ms):
        if not np.isfinite(best[start]):
            continue
        ends = fits[start]
        ends = ends[((ends - start >= floor_ms) | (ends == end)) & (ends % step_ms == 0)]
        best[ends] = np.minimum(best[ends], best[start] + 1)
    return int(best[end])


@pytest.mark.parametrize("tolerance_deg", [0.5, 0.2, 0.1])
def test_greedy_is_within_one_tick_of_the_fewest(tolerance_deg):
    robot = make_robot(6)
    motion = make_motion(
        robot,
        [
            kf([0] * 6, 1),
            kf([50, -30, 20, 0, -60, 10], 2, t=0.45),
            kf([-20, 30, -30, 5, 40, -10], 3, t=1.0),
            kf([0] * 6, 4, t=1.5),
        ],
    )
    trajectory = plan_motion(motion).trajectory
    plan = compile_ticks(trajectory, robot, tolerance_deg=tolerance_deg)
    floor_ms = math.ceil(wire_time_ms(staging_bytes(6)) + 1.5)
    # ticks on the 2 ms lattice: within one of the fewest there, and of the fewest on whole
    # milliseconds within 5 % (plus that one)
    assert len(plan.ticks) <= fewest_ticks(trajectory, tolerance_deg, floor_ms, step_ms=2) + 1
    assert len(plan.ticks) <= 1.05 * fewest_ticks(trajectory, tolerance_deg, floor_ms) + 1


def test_approach_segments_too():
    robot = make_robot(6)
    trajectory = plan_approach(robot, [85, -85, 40, 0, 10, -60], [0] * 6)
    check_plan(robot, trajectory, compile_ticks(trajectory, robot), 0.5)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motions())
def test_random_motions_compile_to_ticks_within_tolerance_bus_floor_and_range(motion):
    trajectory = plan_motion(motion, stretch=True).trajectory
    plan = compile_ticks(trajectory, motion.robot)
    if trajectory.duration_s == 0:
        assert plan.ticks == ()
        return
    check_plan(motion.robot, trajectory, plan, 0.5)


SHIPPED = sorted((REPO / "motions").glob("*/*.yaml"))


def planned(path: Path):
    """A shipped motion and its trajectory (planned once: plan_helpers.shipped_plan)."""
    motion, result = shipped_plan(path)
    return motion, result.trajectory


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_motions_compile_within_tolerance_and_bus_floor(path):
    motion, trajectory = planned(path)
    check_plan(motion.robot, trajectory, compile_ticks(trajectory, motion.robot), 0.5)


@pytest.mark.parametrize("lanes", [2, 7, 64])
@pytest.mark.parametrize("name", ["hexapod18/side_step", "arm6/dance", "tonypi/dance"])
def test_chains_searched_side_by_side_find_the_ticks_of_one_chain(monkeypatch, name, lanes):
    # lanes a few ticks apart (or closer than one) meet, overtake each other and give up short
    # of the next, which the one chain from 0 must not notice
    motion, trajectory = planned(REPO / "motions" / f"{name}.yaml")
    monkeypatch.setattr(ticks, "LANES", 1)
    one_chain = compile_ticks(trajectory, motion.robot)
    monkeypatch.setattr(ticks, "LANES", lanes)
    monkeypatch.setattr(ticks, "LANE_MIN_STEPS", 1)
    assert compile_ticks(trajectory, motion.robot) == one_chain
