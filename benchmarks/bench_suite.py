"""The test suite's wall time, quiet and beside CPU hogs (goal: within ~3 minutes on 2 cores).

Runs the README's test command (``python -m pytest -q -n auto``) once quiet and once beside two
busy-looping processes (one per core of a 2-core machine, killed when the suite ends), and prints
each run's duration, the CPU time the suite's processes used (the same whatever else runs, so
runs on a shared machine compare), the load average it started at, and pytest's closing line;
then how slow the machine ran (benchmarks/machine_speed.py, probed before and after each run).

Run: python benchmarks/bench_suite.py [--hogs 2] [--skip-quiet]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from bench_player import cpu_hogs  # the same hogs as the playback figures
from machine_speed import describe, slowness

REPO = Path(__file__).resolve().parents[1]
GOAL_S = 180.0


def children_cpu_s() -> float:
    """CPU seconds of the finished child processes (and theirs), user and system."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def run_suite() -> tuple[float, float, str]:
    """The suite's wall time and CPU time, and pytest's closing line after the names of any
    failed tests."""
    cpu_before = children_cpu_s()
    started = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "auto", "-p", "no:cacheprovider"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    lines = done.stdout.strip().splitlines()
    failed = [line for line in lines if line.startswith(("FAILED ", "ERROR "))]
    closing = lines[-1] if lines else f"exit status {done.returncode}"
    wall_s, cpu_s = time.monotonic() - started, children_cpu_s() - cpu_before
    return wall_s, cpu_s, "\n".join([*failed, closing])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hogs", type=int, default=2, help="busy processes beside the suite")
    parser.add_argument("--skip-quiet", action="store_true", help="only the run beside the hogs")
    args = parser.parse_args()
    runs = [(f"beside {args.hogs} CPU hogs", args.hogs)]
    if not args.skip_quiet:
        runs.insert(0, ("quiet", 0))
    for name, hogs in runs:
        load = os.getloadavg()[0]
        factors = [slowness()]
        with cpu_hogs(hogs):  # the hogs' CPU is not counted: they end after run_suite
            wall_s, cpu_s, closing = run_suite()
        print(
            f"suite {name}: {wall_s:.0f} s (goal <= {GOAL_S:.0f} s), {cpu_s:.0f} s of CPU, "
            f"load {load:.1f} at the start on {os.cpu_count()} cores: {closing}"
        )
        factors.append(slowness())
        print(f"  {describe(factors)}")


if __name__ == "__main__":
    main()
