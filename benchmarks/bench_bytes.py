"""Bus bytes: choreo's ticks against fixed-period streaming, on the shipped motions.

For each motion (and a generated 10-minute hexapod-sized dance), at the same tolerance:
  choreo          the adaptive ticks: staged moves to the servos whose target changes, one
                  broadcast MOVE_START per tick;
  20 ms stream    what players do today: every 20 ms a MOVE_TIME_WRITE to every servo;
  20 ms staged    every 20 ms, staged moves to the changed servos only, plus one START;
  fixed P ms      the longest fixed period whose path stays within the same tolerance,
                  staged like choreo (how much the adaptive tick length alone buys).
Every path is measured the same way: straight moves between rounded targets, against the smooth
plan, every 0.5 ms. Goal: choreo needs at least 4x fewer bytes than 20 ms streaming.

Run: python benchmarks/bench_bytes.py
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from motion_gen import dance, servo_robot
from rich.console import Console
from rich.table import Table

from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import MOVE_BYTES, QUANTIZATION_DEG, compile_ticks, staging_bytes
from choreo.plan.trajectory import Trajectory
from choreo.robot.types import Robot

TOLERANCE_DEG = 0.5
STREAM_MS = 20
GOAL = 4.0
MOTIONS = sorted(Path(__file__).resolve().parents[1].glob("motions/*/*.yaml"))


def rounded_targets(robot: Robot, trajectory: Trajectory, bounds_ms: np.ndarray) -> np.ndarray:
    angles = trajectory.positions(bounds_ms / 1000)
    return np.array([[round(j.to_units(a)) for j, a in zip(robot.joints, row)] for row in angles])


def deviation_deg(
    robot: Robot, trajectory: Trajectory, bounds_ms: np.ndarray, units: np.ndarray
) -> float:
    times_ms = np.arange(0, bounds_ms[-1] * 2 + 1) / 2
    smooth = trajectory.positions(times_ms / 1000)
    worst = 0.0
    for j, joint in enumerate(robot.joints):
        path = np.interp(times_ms, bounds_ms, [joint.to_deg(u) for u in units[:, j]])
        worst = max(worst, float(np.abs(path - smooth[:, j]).max()))
    return worst


def fixed_period(robot: Robot, trajectory: Trajectory, period_ms: int):
    """Bounds, rounded targets, staged bytes and deviation of streaming every ``period_ms``."""
    end_ms = math.ceil(round(trajectory.duration_s * 1000, 6))
    bounds = np.arange(0, end_ms + period_ms, period_ms)
    units = rounded_targets(robot, trajectory, bounds)
    changed = (units[1:] != units[:-1]).sum(axis=1)
    staged = sum(staging_bytes(int(c)) for c in changed)
    return bounds, units, staged, deviation_deg(robot, trajectory, bounds, units)


def longest_fixed_period(robot: Robot, trajectory: Trajectory, limit_deg: float) -> int:
    """The longest whole-ms period whose path stays within ``limit_deg`` (bisection)."""
    low, high = 1, 400
    while high - low > 1:
        middle = (low + high) // 2
        if fixed_period(robot, trajectory, middle)[3] <= limit_deg:
            low = middle
        else:
            high = middle
    return low


def main() -> None:
    rows = [(str(p.relative_to(p.parents[2])), load_motion(p)) for p in MOTIONS]
    rows.append(("generated dance, 18 servos, 10 min", dance(servo_robot(18), 2000, 600.0)))
    table = Table(title=f"bytes at tolerance {TOLERANCE_DEG}° (+{QUANTIZATION_DEG}° rounding)")
    for header in (
        "motion",
        "s",
        "choreo ticks",
        "choreo bytes",
        "dev °",
        "20 ms stream bytes",
        "dev °",
        "ratio",
        "20 ms staged bytes",
        "ratio",
        "fixed P ms",
        "bytes",
        "ratio",
    ):
        table.add_column(header, justify="left" if header == "motion" else "right")
    worst_ratio = math.inf
    for name, motion in rows:
        robot = motion.robot
        trajectory = plan_motion(motion, stretch=True).trajectory
        plan = compile_ticks(trajectory, robot, tolerance_deg=TOLERANCE_DEG)
        ours = plan.total_bytes
        bounds, _, staged20, dev20 = fixed_period(robot, trajectory, STREAM_MS)
        stream20 = (len(bounds) - 1) * len(robot.joints) * MOVE_BYTES
        period = longest_fixed_period(robot, trajectory, plan.max_deviation_deg)
        fixed_bytes = fixed_period(robot, trajectory, period)[2]
        if ours == 0:  # a motion that holds one pose (tonypi/stand) sends nothing to compare
            table.add_row(
                name, f"{trajectory.duration_s:.1f}", str(len(plan.ticks)), "0", *["-"] * 9
            )
            continue
        worst_ratio = min(worst_ratio, stream20 / ours)
        table.add_row(
            name,
            f"{trajectory.duration_s:.1f}",
            str(len(plan.ticks)),
            str(ours),
            f"{plan.max_deviation_deg:.2f}",
            str(stream20),
            f"{dev20:.2f}",
            f"{stream20 / ours:.1f}x",
            str(staged20),
            f"{staged20 / ours:.1f}x",
            str(period),
            str(fixed_bytes),
            f"{fixed_bytes / ours:.1f}x",
        )
    console = Console(width=200)
    console.print(table)
    verdict = "met" if worst_ratio >= GOAL else "NOT met"
    console.print(
        f"fewest-bytes ratio against 20 ms streaming: {worst_ratio:.1f}x "
        f"(goal >= {GOAL:g}x: {verdict})"
    )


if __name__ == "__main__":
    main()
