"""How fast this machine runs Python at the moment, to read a benchmark's seconds by.

The development machine is a virtual one on a shared host: the same work takes from 1.0x to
2.7x as long depending on the hour (seen over November 2026, idle inside the machine each
time). A figure in seconds means little without that factor, so the benchmarks whose goals are
in seconds print it beside their figures: the CPU time of a fixed Python loop, against what it
took at a calm hour.
"""

from __future__ import annotations

import statistics
import time

# The loop below, as a script's top level (its names global, as in ``python -c``): 10**7 steps
# took 1.05 s of CPU at calm hours on the development machine, so its 2 * 10**6 take 0.21 s.
CALM_LOOP_S = 0.21
_LOOP = compile("total = 0\nfor step in range(2_000_000):\n    total += step\n", "loop", "exec")


def _loop() -> float:
    """CPU seconds of two million additions in a Python loop."""
    start = time.process_time()
    exec(_LOOP, {})
    return time.process_time() - start


def slowness() -> float:
    """How many times longer than at a calm hour Python takes now (1.0: a calm hour)."""
    return statistics.median(_loop() for _ in range(3)) / CALM_LOOP_S


def describe(factors: list[float]) -> str:
    """One line on the machine's speed over a benchmark's probes."""
    return (
        f"machine speed: Python took {statistics.median(factors):.2f}x (from {min(factors):.2f}x "
        f"to {max(factors):.2f}x) as long as at a calm hour, over {len(factors)} probes"
    )
