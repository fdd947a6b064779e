"""Real and virtual clocks.

Everything that waits (the emulator's wire timing, the player's deadlines, the driver's read
timeouts) takes a clock, so tests run on a ``VirtualClock``: deterministic and instant.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol

from choreo.core.arguments import NON_NEGATIVE, NUMBER, Range, check_number

SPIN_S = Range(at_least=0, at_most=0.1, unit=" s")  # a busy wait longer than this wastes a core


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on a monotonic time line."""

    def sleep_until(self, deadline_s: float) -> None:
        """Return once ``now() >= deadline_s``."""


class RealClock:
    """``time.monotonic``; a wait is slept to its deadline, not spun.

    On a busy computer the scheduler wakes a sleeping thread promptly, ahead of the programs
    that keep the CPU busy, while a thread that spins uses up its share of the CPU and then waits
    behind them, milliseconds late (``benchmarks/bench_player.py``). ``time.sleep`` sleeps on the
    monotonic clock to an absolute time on Linux (``clock_nanosleep``), so nothing is gained by
    spinning. ``spin_s``: spin the last part anyway, where one wake-up must be as exact as the
    CPU allows (a UART's direction line switched right after the last stop bit).
    """

    def __init__(self, spin_s: float = 0.0):
        self.spin_s = check_number("spin_s", spin_s, SPIN_S)

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, deadline_s: float) -> None:
        while (remaining := deadline_s - time.monotonic()) > self.spin_s:
            time.sleep(remaining - self.spin_s)  # again if woken early (a signal)
        while time.monotonic() < deadline_s:
            pass


class VirtualClock:
    """A clock that only moves when somebody sleeps (or calls ``advance``)."""

    def __init__(self, start_s: float = 0.0):
        self._now = check_number("start_s", start_s, NUMBER)
        self._lock = threading.Lock()

    def now(self) -> float:
        return self._now

    def sleep_until(self, deadline_s: float) -> None:
        with self._lock:
            self._now = max(self._now, deadline_s)

    def advance(self, dt_s: float) -> None:
        check_number("dt_s", dt_s, NON_NEGATIVE)
        with self._lock:
            self._now += dt_s
