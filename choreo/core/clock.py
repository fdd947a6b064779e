"""Real and virtual clocks.

Everything that waits (the emulator's wire timing, the player's deadlines, the driver's read
timeouts) takes a clock, so tests run on a ``VirtualClock``: deterministic and instant.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Protocol

from choreo.core.arguments import NON_NEGATIVE, NUMBER, Range, check_number
from choreo.errors import OptionError

SPIN_S = Range(at_least=0, at_most=0.1, unit=" s")  # a busy wait longer than this wastes a core
LONGEST_SLEEP_S = 86400.0  # one sleep at most: the OS's sleep overflows on a far deadline


def reachable_deadline(deadline_s: object) -> float:
    """``deadline_s`` as a float, if it is a time a clock can reach: a NaN would return at
    once and an infinity never (minus infinity, long past, returns at once). The common case,
    a float, costs two comparisons: every wait on the bus passes here."""
    if isinstance(deadline_s, float) and deadline_s < math.inf:  # numpy's too; False for NaN
        return deadline_s
    return check_number("deadline_s", deadline_s)  # a whole number, or refused as it is


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
        deadline_s = reachable_deadline(deadline_s)
        while (remaining := deadline_s - time.monotonic()) > self.spin_s:
            time.sleep(min(remaining - self.spin_s, LONGEST_SLEEP_S))
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
        deadline_s = reachable_deadline(deadline_s)
        with self._lock:
            self._now = max(self._now, deadline_s)

    def advance(self, dt_s: float) -> None:
        check_number("dt_s", dt_s, NON_NEGATIVE)
        with self._lock:
            if not math.isfinite(self._now + dt_s):
                past = f"{self._now:g} s + {dt_s:g} s"
                raise OptionError("dt_s", f"takes the clock past any time it can tell: {past}")
            self._now += dt_s
