"""Inverse kinematics speed: time per solved keyframe (median, p95, worst case).

1. The shipped motions with ``sites:``/``body:``/``gait:`` keyframes, loaded from their files
   (every IK solve timed).
2. arm6: random reachable tool targets (position + pitch, from FK of random in-limit angles),
   each seeded from the previous solution, as a motion's keyframes are.
3. arm6: small tool moves (5-10 mm, pitch kept) from random poses: a small move in space should
   stay a small move in joints (the solution nearest the seed); counts those that do not.
4. hexapod18: random body poses (all six feet planted); tonypi: random hand targets.
5. Hard targets: at the edge of the arm's reach, at its singularities, and out of reach (those
   must fail fast; the last one through a motion file, with the message its user reads).
6. hexapod18: loading a motion with a 100-step tripod gait (800 keyframes solved by IK).

Run: python benchmarks/bench_ik.py [--targets N]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from choreo.errors import ChoreoError
from choreo.motion.gait import BodyPose, feet_under_body
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.robot.kinematics import Kinematics, SiteGoal, Solution
from choreo.robot.robot_file import load_robot

ROOT = Path(__file__).resolve().parents[1]
Took = tuple[float, float]  # (wall-clock ms, CPU ms) of one solve
ALL: list[Took] = []  # every solve timed here, for the summary


def robot_kinematics(name: str) -> Kinematics:
    return Kinematics(load_robot(ROOT / "models" / name / "robot.yaml"))


def spread(ms: list[float]) -> str:
    return (
        f"median {statistics.median(ms):.2f} ms, p95 {np.percentile(ms, 95):.2f} ms, "
        f"worst {max(ms):.1f} ms"
    )


def report(what: str, times: list[Took], failed: int, summary: bool = False) -> None:
    """Per keyframe, CPU time first: on a shared machine the wall clock's worst cases are the
    scheduler's (another process ran), not the solver's."""
    if not summary:
        ALL.extend(times)
    wall, cpu = [w for w, _ in times], [c for _, c in times]
    print(
        f"{what}: {spread(cpu)} CPU per keyframe (wall clock: {spread(wall)}) over "
        f"{len(times)} ({failed} not reached)"
    )


def clock() -> Took:
    return time.perf_counter() * 1000, time.process_time() * 1000


def since(start: Took) -> Took:
    now = clock()
    return now[0] - start[0], now[1] - start[1]


def timed_solve(kin: Kinematics, goals: list[SiteGoal], seed) -> tuple[Solution, Took]:
    start = clock()
    solution = kin.solve(goals, seed)
    return solution, since(start)


@contextmanager
def every_solve_timed() -> Iterator[list[tuple[Took, bool]]]:
    """Times each Kinematics.solve made while loading motions (and whether it reached)."""
    calls: list[tuple[Took, bool]] = []
    solve = Kinematics.solve

    def timed(self, *args, **kwargs):
        start = clock()
        solution = solve(self, *args, **kwargs)
        calls.append((since(start), solution.ok))
        return solution

    Kinematics.solve = timed  # type: ignore[method-assign]
    try:
        yield calls
    finally:
        Kinematics.solve = solve  # type: ignore[method-assign]


def bench_shipped() -> None:
    for path in sorted((ROOT / "motions").glob("*/*.yaml")):
        with every_solve_timed() as calls:
            load_motion(path)
        if not calls:  # joint keyframes only
            continue
        times = [ms for ms, _ in calls]
        report(f"{path.parent.name}/{path.name}", times, sum(not ok for _, ok in calls))


def seeded_chain(kin: Kinematics, goals: list[list[SiteGoal]], seed) -> tuple[list[Took], int]:
    times, failed = [], 0
    for goal in goals:
        solution, ms = timed_solve(kin, goal, seed)
        times.append(ms)
        failed += not solution.ok
        seed = solution.angles_deg
    return times, failed


def bench_arm(n: int) -> None:
    kin = robot_kinematics("arm6")
    rng = np.random.default_rng(1)
    goals: list[list[SiteGoal]] = []
    while len(goals) < n:
        pose = kin.site_pose("tool", rng.uniform(kin.lower_deg, kin.upper_deg))
        if pose.position_mm[2] >= 20:  # above the table
            goals.append([SiteGoal("tool", tuple(pose.position_mm), pose.pitch_deg)])
    report("arm6 tool (position + pitch), random targets", *seeded_chain(kin, goals, home(kin)))


def bench_small_moves(n: int) -> None:
    kin = robot_kinematics("arm6")
    rng = np.random.default_rng(3)
    times: list[Took] = []
    jumps, failed, worst = 0, 0, 0.0
    while len(times) < n:
        seed = rng.uniform(kin.lower_deg, kin.upper_deg)
        start = kin.site_pose("tool", seed)
        if start.position_mm[2] < 20:
            continue
        direction = rng.normal(size=3)
        move = direction / np.linalg.norm(direction) * rng.uniform(5, 10)
        goal = [SiteGoal("tool", tuple(start.position_mm + move), start.pitch_deg)]
        solution, ms = timed_solve(kin, goal, seed)
        times.append(ms)
        failed += not solution.ok
        if solution.ok:
            jump = float(np.abs(solution.angles_deg - seed).max())
            worst = max(worst, jump)
            jumps += jump > 30
    report("arm6 tool moved 5-10 mm", times, failed)
    print(f"  reached with a joint moving over 30°: {jumps} of {n - failed} (largest {worst:.0f}°)")


def bench_body(n: int) -> None:
    kin = robot_kinematics("hexapod18")
    stance = np.array([kin.site_pose(foot, home(kin)).position_mm for foot in kin.feet()])
    rng = np.random.default_rng(2)
    goals = []
    for _ in range(n):
        x, y, z = rng.uniform(-20, 20, 3)
        roll, pitch, yaw = rng.uniform(-6, 6, 3)
        feet = feet_under_body(stance, BodyPose(x, y, z, roll, pitch, yaw))
        goals.append([SiteGoal(f, tuple(p)) for f, p in zip(kin.feet(), feet)])
    report("hexapod18 body pose (6 feet), random poses", *seeded_chain(kin, goals, home(kin)))


def bench_hands(n: int) -> None:
    kin = robot_kinematics("tonypi")
    rng = np.random.default_rng(4)
    goals = []
    for k in range(n):
        hand = ("left_hand", "right_hand")[k % 2]
        at = kin.site_pose(hand, rng.uniform(kin.lower_deg, kin.upper_deg)).position_mm
        goals.append([SiteGoal(hand, tuple(at))])
    report("tonypi one hand, random targets", *seeded_chain(kin, goals, home(kin)))


def home(kin: Kinematics) -> np.ndarray:
    return np.array(kin.robot.pose_vector("home"), dtype=float)


# The arm's shoulder pivot is 106 mm above its base (turntable 66 mm + 40 mm), and the tool
# site 335 mm from it when the arm is straight (upper arm 100, forearm 95, wrist 50, hand 90).
SHOULDER_MM = np.array([0.0, 0.0, 106.0])
REACH_MM = 335.0


def along(direction_deg: tuple[float, float], distance_mm: float) -> tuple[float, float, float]:
    """The point ``distance_mm`` from the shoulder, at (heading, elevation) in degrees."""
    heading, elevation = np.radians(direction_deg)
    unit = np.array(
        [
            np.cos(elevation) * np.cos(heading),
            np.cos(elevation) * np.sin(heading),
            np.sin(elevation),
        ]
    )
    x, y, z = SHOULDER_MM + distance_mm * unit
    return float(x), float(y), float(z)


HARD: dict[str, list[tuple[tuple[float, float, float], float | None]]] = {
    # 1-3 mm inside the straight arm's reach: the arm must stretch almost straight (the elbow
    # and wrist singular), the pitch then fixed by the direction
    "at the edge of reach": [
        (along((heading, elevation), REACH_MM - inside), None)
        for heading in (0, 60, -100)
        for elevation in (0, 30, 75)
        for inside in (1.0, 3.0)
    ],
    # on the base's yaw axis (any base_yaw will do: a singularity), straight up and reaching up
    "at singularities": [
        ((0.0, 0.0, z), pitch) for z in (300.0, 380.0, 430.0) for pitch in (90.0, 45.0, None)
    ],
    # past the reach (by 5 mm to 1 m), and reachable points asked with a pitch the arm cannot
    # give there (pointing straight up at the far edge of the reach)
    "out of reach (must fail)": [
        (along((heading, 20), REACH_MM + beyond), None)
        for heading in (0, 90)
        for beyond in (5.0, 50.0, 700.0)
    ]
    + [(along((heading, 0), REACH_MM - 20), 90.0) for heading in (0, 90)],
}


def bench_hard() -> None:
    kin = robot_kinematics("arm6")
    seeds = [home(kin), np.array(kin.robot.pose_vector("ready"), dtype=float)]
    for what, targets in HARD.items():
        times: list[Took] = []
        failed = 0
        for at, pitch in targets:
            for seed in seeds:
                solution, ms = timed_solve(kin, [SiteGoal("tool", at, pitch)], seed)
                times.append(ms)
                failed += not solution.ok
        report(f"arm6 {what}", times, failed)


UNREACHABLE_MOTION = """robot: arm6
keyframes:
  - pose: home
  - sites: {tool: {at: [400, 0, 300], pitch: -30}}
    after: 1.0
"""


def bench_unreachable_file() -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "too_far.yaml"
        path.write_text(UNREACHABLE_MOTION)
        t0 = time.perf_counter()
        try:
            load_motion(path)
            message = "loaded (expected an error)"
        except ChoreoError as error:
            message = str(error).replace(folder + "/", "")
        took = (time.perf_counter() - t0) * 1000
    print(f"an unreachable sites: keyframe, the whole file loaded in {took:.0f} ms:\n  {message}")


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
    sections: list[Callable[[], None]] = [
        bench_shipped,
        lambda: bench_arm(args.targets),
        lambda: bench_small_moves(args.targets),
        lambda: bench_body(args.targets),
        lambda: bench_hands(args.targets),
        bench_hard,
    ]
    for section in sections:
        section()
    report("all of the above", ALL, 0, summary=True)
    bench_unreachable_file()
    bench_gait()


if __name__ == "__main__":
    main()
