"""The test suite's wall time, quiet and beside CPU hogs (goal: within ~3 minutes on 2 cores).

Runs the README's test command (``python -m pytest -q -n auto``) once quiet and once beside two
busy-looping processes (one per core of a 2-core machine, killed when the suite ends), and prints
each run's duration and pytest's closing line.

Run: python benchmarks/bench_suite.py [--hogs 2] [--skip-quiet]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from bench_player import cpu_hogs  # the same hogs as the playback figures

REPO = Path(__file__).resolve().parents[1]
GOAL_S = 180.0


def run_suite() -> tuple[float, str]:
    """The suite's wall time, and pytest's closing line after the names of any failed tests."""
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
    return time.monotonic() - started, "\n".join([*failed, closing])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hogs", type=int, default=2, help="busy processes beside the suite")
    parser.add_argument("--skip-quiet", action="store_true", help="only the run beside the hogs")
    args = parser.parse_args()
    runs = [(f"beside {args.hogs} CPU hogs", args.hogs)]
    if not args.skip_quiet:
        runs.insert(0, ("quiet", 0))
    for name, hogs in runs:
        with cpu_hogs(hogs):
            seconds, closing = run_suite()
        print(f"suite {name}: {seconds:.0f} s (goal <= {GOAL_S:.0f} s): {closing}")


if __name__ == "__main__":
    main()
