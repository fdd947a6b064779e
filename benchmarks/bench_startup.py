"""Start-up: how long a `choreo` command takes as a whole process, from exec to exit.

Bus-only commands (scan, servo, emulate) must not pay for MuJoCo, matplotlib or a robot file:
goal under 0.3 s. For comparison, a bare Python and a command that reads a robot (and so checks
its MuJoCo model) are timed too. `scan` and `servo info` also include the emulated bus's real
wire time (and, for `servo info`, two 50 ms timeouts: an LX-16A stays silent on two reads).
Each command runs once to warm the file cache, then RUNS times; the median and the spread are
printed (the machine is shared: quote medians).

Run: python benchmarks/bench_startup.py [RUNS]
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOAL_S = 0.3
COMMANDS = {
    "python -c pass (floor)": [sys.executable, "-c", "pass"],
    "choreo --version": [sys.executable, "-m", "choreo", "--version"],
    "choreo scan --help": [sys.executable, "-m", "choreo", "scan", "--help"],
    "choreo scan --ids 1-6 (emulated bus)": [
        sys.executable, "-m", "choreo", "scan", "--ids", "1-6",
    ],
    "choreo servo info --id 1 (+0.12 s emulated wire time)": [
        sys.executable, "-m", "choreo", "servo", "info", "--id", "1",
    ],
    "choreo emulate --help": [sys.executable, "-m", "choreo", "emulate", "--help"],
    "choreo validate arm6/wave (reads a robot: MuJoCo)": [
        sys.executable, "-m", "choreo", "validate", "motions/arm6/wave.yaml",
    ],
}  # fmt: skip


def wall_times_s(command: list[str], runs: int) -> list[float]:
    subprocess.run(command, cwd=ROOT, capture_output=True, check=True)  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(command, cwd=ROOT, capture_output=True, check=True)
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    print(f"wall time per process, {runs} runs after a warm-up; goal for bus-only: < {GOAL_S} s")
    print(f"{'command':<52} {'median':>8} {'min':>8} {'max':>8}")
    for name, command in COMMANDS.items():
        times = wall_times_s(command, runs)
        print(
            f"{name:<52} {statistics.median(times):>7.3f}s {min(times):>7.3f}s {max(times):>7.3f}s"
        )


if __name__ == "__main__":
    main()
