"""Planning + tick compiling speed on a long motion.

A generated 10-minute, 18-servo, 2,000-keyframe motion (benchmarks/motion_gen.py): time
``plan_motion`` and ``compile_ticks`` separately, best and median of several runs.
Goal: plan + compile_ticks under 1 s on the 2-core development machine.

Run: python benchmarks/bench_planner.py [--runs N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from motion_gen import dance, servo_robot

from choreo.plan.planner import plan_motion
from choreo.plan.ticks import compile_ticks

GOAL_S = 1.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()

    robot = servo_robot(18)
    motion = dance(robot, n_keyframes=2000, duration_s=600.0)
    plan_s, ticks_s, total_s, cpu_s = [], [], [], []
    for _ in range(args.runs):
        c0 = time.process_time()
        t0 = time.perf_counter()
        result = plan_motion(motion, stretch=True)
        t1 = time.perf_counter()
        ticks = compile_ticks(result.trajectory, robot)
        t2 = time.perf_counter()
        cpu_s.append(time.process_time() - c0)
        plan_s.append(t1 - t0)
        ticks_s.append(t2 - t1)
        total_s.append(t2 - t0)

    trajectory = result.trajectory
    print(
        f"motion: {len(robot.joints)} servos, {len(motion.keyframes)} keyframes, "
        f"{trajectory.duration_s:.1f} s ({len(result.stretches)} keyframes stretched)"
    )
    mean_ms = trajectory.duration_s * 1000 / len(ticks.ticks)
    print(
        f"result: {len(ticks.ticks)} ticks (mean {mean_ms:.0f} ms), "
        f"{ticks.total_bytes} bytes, max deviation {ticks.max_deviation_deg:.3f}°, "
        f"peak bus use {ticks.peak_bus_use:.0%}"
    )
    for name, runs in (
        ("plan", plan_s),
        ("compile_ticks", ticks_s),
        ("plan + compile_ticks", total_s),
        ("(CPU time)", cpu_s),
    ):
        print(
            f"{name:>15}: best {min(runs):.3f} s, median {statistics.median(runs):.3f} s "
            f"over {len(runs)} runs"
        )
    verdict = "met" if min(total_s) < GOAL_S else "NOT met"
    load = os.getloadavg()[0]
    print(
        f"goal plan + compile_ticks < {GOAL_S:g} s: {verdict} (load average {load:.1f} on "
        f"{os.cpu_count()} cores while measuring)"
    )


if __name__ == "__main__":
    main()
