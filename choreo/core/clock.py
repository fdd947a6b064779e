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
    """``time.monotonic``; sleeps, then spins the last ``spin_s`` for a precise wake-up."""

    def __init__(self, spin_s: float = 0.001):
        self.spin_s = check_number("spin_s", spin_s, SPIN_S)

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, deadline_s: float) -> None:
        remaining = deadline_s - time.monotonic()
        if remaining > self.spin_s:
            time.sleep(remaining - self.spin_s)
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
