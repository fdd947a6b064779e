"""``choreo plan`` end to end on a long motion file: loading, planning and compiling, as a user
runs it.

A generated 10-minute, 2,000-keyframe dance for the 18-servo hexapod (benchmarks/motion_gen.py)
is written as a motion file; ``python -m choreo plan FILE --stretch`` is then run as a
subprocess several times (best and median wall time), and ``load_motion`` alone is timed
in-process to show how much of it is reading the file.
Goal: the whole command under 1.5 s on the 2-core development machine.

Run: python benchmarks/bench_load.py [--runs N]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from motion_gen import dance

from choreo.motion.motion_file import load_motion
from choreo.motion.writer import motion_text, robot_reference
from choreo.robot.robot_file import load_robot

GOAL_S = 1.5
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


def time_cli(path: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of one ``choreo plan`` run; CPU time (user + system of the child)
    suffers less than wall time when other work shares the machine."""
    cpu_before = _children_cpu_s()
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "choreo", "plan", str(path), "--stretch"],
        cwd=REPO,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return time.perf_counter() - start, _children_cpu_s() - cpu_before


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_load(path: Path) -> float:
    start = time.perf_counter()
    load_motion(path)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path = write_dance(Path(folder))
        motion = load_motion(path)
        size_kb = path.stat().st_size / 1000
        print(
            f"motion: {len(motion.robot.joints)} servos, {len(motion.keyframes)} keyframes, "
            f"{size_kb:.0f} kB of YAML"
        )
        load_s = [time_load(path) for _ in range(args.runs)]
        cli = [time_cli(path) for _ in range(args.runs)]
    cli_s = [wall for wall, _ in cli]
    for name, runs in (
        ("load_motion", load_s),
        ("choreo plan (CLI)", cli_s),
        ("(its CPU time)", [cpu for _, cpu in cli]),
    ):
        print(
            f"{name:>18}: best {min(runs):.3f} s, median {statistics.median(runs):.3f} s "
            f"over {len(runs)} runs"
        )
    verdict = "met" if min(cli_s) < GOAL_S else "NOT met"
    print(
        f"goal choreo plan < {GOAL_S:g} s end to end: {verdict} (load average "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores while measuring)"
    )


if __name__ == "__main__":
    main()
