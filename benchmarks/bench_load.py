"""``choreo plan`` end to end on a long motion file: loading, planning and compiling, as a user
runs it.

A generated 10-minute, 2,000-keyframe dance for the 18-servo hexapod (benchmarks/motion_gen.py)
is written as a motion file; ``python -m choreo plan FILE --stretch`` is then run as a
subprocess several times (best and median wall time, and its CPU time), and its stages are timed
in-process (CPU time, after a warm-up run) to show where the time goes: YAML loading, reading the
motion (and its robot), planning, ticks, report; start-up is what the command takes beyond them
(the interpreter, imports). The robot's model check is remembered from the warm-up on, as from a
user's second run (choreo.robot.check_cache), so MuJoCo is not loaded.
choreo's modules are byte-compiled first, as pip does when it installs them: where
PYTHONDONTWRITEBYTECODE is set (it is in this project's development environment) each run would
otherwise compile them again, some 0.1-0.2 s that no installed choreo spends.
Goal: the whole command within 1.0 s (median) on the 2-core development machine. The machine's
speed is probed beside each run (benchmarks/machine_speed.py), and the median is also given as it
would be at a calm hour.

Run: python benchmarks/bench_load.py [--runs N]
"""

from __future__ import annotations

import argparse
import compileall
import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine_speed import describe, slowness
from motion_gen import dance

from choreo.cli.plan_commands import print_report
from choreo.core.collector import collector_paused
from choreo.core.yaml_source import parse_yaml_file
from choreo.motion.motion_file import load_motion
from choreo.motion.writer import motion_text, robot_reference
from choreo.plan.pipeline import CompiledMotion
from choreo.plan.planner import plan_motion
from choreo.plan.report import plan_report
from choreo.plan.ticks import compile_ticks
from choreo.robot.robot_file import load_robot

GOAL_S = 1.0  # median
REPO = Path(__file__).resolve().parents[1]


def write_dance(folder: Path) -> Path:
    robot = load_robot(REPO / "models/hexapod18/robot.yaml")
    motion = dance(robot, n_keyframes=2000, duration_s=600.0)
    path = folder / "long_dance.yaml"
    path.write_text(
        motion_text(robot, motion.keyframes, robot_ref=robot_reference(robot, path)),
        encoding="utf-8",
    )
    return path


def time_cli(path: Path) -> tuple[float, float, float]:
    """(wall, CPU) seconds of one ``choreo plan`` run, and how slow the machine was around it;
    CPU time (user + system of the child) suffers less than wall time when other work shares
    the machine."""
    slow_before = slowness()
    cpu_before = _children_cpu_s()
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "choreo", "plan", str(path), "--stretch"],
        cwd=REPO,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    wall_s, cpu_s = time.perf_counter() - start, _children_cpu_s() - cpu_before
    return wall_s, cpu_s, (slow_before + slowness()) / 2


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def stage_times_s(path: Path) -> dict[str, float]:
    """CPU seconds of each stage of ``choreo plan --stretch`` on ``path``, in-process."""
    times = {}
    clock = time.process_time
    start = clock()
    with collector_paused():  # as load_motion reads it
        parse_yaml_file(path)
    times["YAML loading"] = clock() - start
    start = clock()
    motion = load_motion(path)
    times["motion reading"] = clock() - start - times["YAML loading"]  # it parses the YAML too
    with collector_paused():  # as compile_motion plans and compiles
        start = clock()
        plan = plan_motion(motion, stretch=True)
        times["planning"] = clock() - start
        start = clock()
        ticks = compile_ticks(plan.trajectory, motion.robot)
        times["ticks"] = clock() - start
    start = clock()
    compiled = CompiledMotion(motion.robot, plan.trajectory, ticks, plan.stretches)
    with open(os.devnull, "w") as devnull, contextlib.redirect_stdout(devnull):
        print_report(plan_report(motion, compiled, motion.speed, keyframes=False))
    times["report"] = clock() - start
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    compileall.compile_dir(REPO / "choreo", quiet=1)  # as an installed choreo has it
    with tempfile.TemporaryDirectory() as folder:
        path = write_dance(Path(folder))
        motion = load_motion(path)
        size_kb = path.stat().st_size / 1000
        print(
            f"motion: {len(motion.robot.joints)} servos, {len(motion.keyframes)} keyframes, "
            f"{size_kb:.0f} kB of YAML"
        )
        stage_times_s(path)  # warm-up
        stages = [stage_times_s(path) for _ in range(args.runs)]
        cli = [time_cli(path) for _ in range(args.runs)]
    cli_s = [wall for wall, _, _ in cli]
    cpu_s = [cpu for _, cpu, _ in cli]
    factors = [factor for _, _, factor in cli]
    for name, runs in (("choreo plan (CLI)", cli_s), ("(its CPU time)", cpu_s)):
        print(
            f"{name:>18}: best {min(runs):.3f} s, median {statistics.median(runs):.3f} s "
            f"over {len(runs)} runs"
        )
    medians = {name: statistics.median(run[name] for run in stages) for name in stages[0]}
    cpu = statistics.median(cpu_s)
    print("where its CPU time goes (medians, in-process stages after a warm-up):")
    print(f"{'start-up':>18}: {cpu - sum(medians.values()):.3f} s (the rest: Python, imports)")
    for name, seconds in medians.items():
        print(f"{name:>18}: {seconds:.3f} s")
    verdict = "met" if statistics.median(cli_s) <= GOAL_S else "NOT met"
    print(
        f"goal choreo plan <= {GOAL_S:g} s end to end (median): {verdict} (load average "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores while measuring)"
    )
    calm_s = statistics.median(cpu / factor for cpu, factor in zip(cpu_s, factors, strict=True))
    print(f"{describe(factors)}; its CPU time's median at a calm hour's speed: {calm_s:.3f} s")


if __name__ == "__main__":
    main()
