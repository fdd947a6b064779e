"""Inverse kinematics speed: time per Cartesian keyframe, and expanding a 100-step gait.

1. arm6: random reachable tool targets (position + pitch, from FK of random in-limit angles),
   each seeded from the previous solution, as a motion's keyframes are.
2. hexapod18: random body poses (all six feet planted), seeded from the previous one.
3. hexapod18: loading a motion with a 100-step tripod gait (800 keyframes solved by IK), from
   the YAML file to the joint keyframes, and planning it.

Run: python benchmarks/bench_ik.py [--targets N]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from choreo.motion.gait import BodyPose, feet_under_body
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.robot.kinematics import Kinematics, SiteGoal
from choreo.robot.robot_file import load_robot

MODELS = Path(__file__).resolve().parents[1] / "models"


def per_keyframe_ms(solve, goals, seed) -> tuple[list[float], int]:
    times, failed = [], 0
    for goal in goals:
        t0 = time.perf_counter()
        solution = solve(goal, seed)
        times.append((time.perf_counter() - t0) * 1000)
        failed += not solution.ok
        seed = solution.angles_deg
    return times, failed


def report(what: str, times: list[float], failed: int) -> None:
    print(
        f"{what}: median {statistics.median(times):.2f} ms, mean {statistics.mean(times):.2f} ms, "
        f"max {max(times):.1f} ms per keyframe over {len(times)} ({failed} not reached)"
    )


def bench_arm(n: int) -> None:
    robot = load_robot(MODELS / "arm6" / "robot.yaml")
    kin = Kinematics(robot)
    rng = np.random.default_rng(1)
    goals = []
    while len(goals) < n:
        pose = kin.site_pose("tool", rng.uniform(kin.lower_deg, kin.upper_deg))
        if pose.position_mm[2] >= 20:  # above the table
            goals.append([SiteGoal("tool", tuple(pose.position_mm), pose.pitch_deg)])
    times, failed = per_keyframe_ms(kin.solve, goals, robot.pose_vector("home"))
    report("arm6 tool (position + pitch), random targets", times, failed)


def bench_small_moves(n: int) -> None:
    """Small tool moves (5-10 mm, pitch kept) from random reachable poses: a small move in space
    should stay a small move in joints (the solution nearest the seed)."""
    robot = load_robot(MODELS / "arm6" / "robot.yaml")
    kin = Kinematics(robot)
    rng = np.random.default_rng(3)
    times, jumps, failed, worst = [], 0, 0, 0.0
    while len(times) < n:
        seed = rng.uniform(kin.lower_deg, kin.upper_deg)
        start = kin.site_pose("tool", seed)
        if start.position_mm[2] < 20:
            continue
        direction = rng.normal(size=3)
        move = direction / np.linalg.norm(direction) * rng.uniform(5, 10)
        goal = [SiteGoal("tool", tuple(start.position_mm + move), start.pitch_deg)]
        t0 = time.perf_counter()
        solution = kin.solve(goal, seed)
        times.append((time.perf_counter() - t0) * 1000)
        failed += not solution.ok
        if solution.ok:
            jump = float(np.abs(solution.angles_deg - seed).max())
            worst = max(worst, jump)
            jumps += jump > 30
    report("arm6 tool moved 5-10 mm", times, failed)
    print(f"  reached with a joint moving over 30°: {jumps} of {n - failed} (largest {worst:.0f}°)")


def bench_body(n: int) -> None:
    robot = load_robot(MODELS / "hexapod18" / "robot.yaml")
    kin = Kinematics(robot)
    home = robot.pose_vector("home")
    stance = np.array([kin.site_pose(foot, home).position_mm for foot in kin.feet()])
    rng = np.random.default_rng(2)
    goals = []
    for _ in range(n):
        x, y, z = rng.uniform(-20, 20, 3)
        roll, pitch, yaw = rng.uniform(-6, 6, 3)
        feet = feet_under_body(stance, BodyPose(x, y, z, roll, pitch, yaw))
        goals.append([SiteGoal(f, tuple(p)) for f, p in zip(kin.feet(), feet)])
    times, failed = per_keyframe_ms(kin.solve, goals, home)
    report("hexapod18 body pose (6 feet), random poses", times, failed)


def bench_gait(steps: int = 100) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "long_walk.yaml"
        path.write_text(
            "robot: hexapod18\nkeyframes:\n  - pose: home\n"
            f"  - gait: {{pattern: tripod, steps: {steps}, stride: 40, turn: 2}}\n"
        )
        t0 = time.perf_counter()
        motion = load_motion(path)
        t1 = time.perf_counter()
        plan_motion(motion)
        t2 = time.perf_counter()
    print(
        f"hexapod18 {steps}-step tripod gait: {len(motion.keyframes)} keyframes loaded and "
        f"solved in {t1 - t0:.2f} s ({(t1 - t0) / (len(motion.keyframes) - 1) * 1000:.2f} ms "
        f"per keyframe), planned in {t2 - t1:.2f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=300)
    args = parser.parse_args()
    bench_arm(args.targets)
    bench_small_moves(args.targets)
    bench_body(args.targets)
    bench_gait()


if __name__ == "__main__":
    main()
