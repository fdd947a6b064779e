"""Start-up: how long a `choreo` command takes as a whole process, from exec to exit.

Bus-only commands (scan, servo, emulate) must not pay for MuJoCo, matplotlib, rich or the other
commands' modules: `choreo scan --help` should start in at most twice the time of importing the
libraries every command needs (`python -c "import numpy, yaml, ruckig"`), printed side by side
with their ratio, as the machine's speed cancels out of it. For comparison, a bare Python and a
command that reads a robot (and so checks its MuJoCo model) are timed too. `scan` and `servo
info` also include the emulated bus's real wire time (and, for `servo info`, two 50 ms
timeouts: an LX-16A stays silent on two reads).
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
GOAL_RATIO = 2.0
LIBRARIES = "python -c 'import numpy, yaml, ruckig'"
SCAN_HELP = "choreo scan --help"
COMMANDS = {
    "python -c pass (floor)": [sys.executable, "-c", "pass"],
    LIBRARIES: [sys.executable, "-c", "import numpy, yaml, ruckig"],
    "choreo --version": [sys.executable, "-m", "choreo", "--version"],
    SCAN_HELP: [sys.executable, "-m", "choreo", "scan", "--help"],
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
    print(f"wall time per process, {runs} runs after a warm-up")
    print(f"{'command':<52} {'median':>8} {'min':>8} {'max':>8}")
    medians = {}
    for name, command in COMMANDS.items():
        times = wall_times_s(command, runs)
        medians[name] = statistics.median(times)
        print(f"{name:<52} {medians[name]:>7.3f}s {min(times):>7.3f}s {max(times):>7.3f}s")
    ratio = medians[SCAN_HELP] / medians[LIBRARIES]
    verdict = "met" if ratio <= GOAL_RATIO else "NOT met"
    print(
        f"{SCAN_HELP} {medians[SCAN_HELP]:.3f} s vs {LIBRARIES} {medians[LIBRARIES]:.3f} s: "
        f"{ratio:.2f}x (goal <= {GOAL_RATIO:g}x: {verdict})"
    )


if __name__ == "__main__":
    main()
