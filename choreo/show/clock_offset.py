"""How far a performer's wall clock is from the conductor's, measured by round trips.

Each round trip gives the conductor's clock when the question left (``sent_s``) and when the
answer came back (``received_s``) and the performer's clock when it answered. Assuming the two
legs take equally long, the performer's clock read ``(sent_s + received_s) / 2`` on the
conductor's at that moment; the sample with the shortest round trip is the least disturbed one
(as NTP's clock filter picks), and half its round trip bounds the error of the estimate.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

ROUND_TRIPS = 8
# Taken one at a time when the first ROUND_TRIPS cannot show the clocks within the bound: on a busy
# machine or network even the shortest of a few round trips can be slow (3 ms seen beside two CPU
# hogs, on one machine whose clocks are the same), and the bound was then the measurement's fault.
MORE_ROUND_TRIPS = 56


@dataclass(frozen=True)
class RoundTrip:
    sent_s: float  # conductor's clock
    remote_s: float  # performer's clock, when it answered
    received_s: float  # conductor's clock

    @property
    def rtt_s(self) -> float:
        return self.received_s - self.sent_s

    @property
    def offset_s(self) -> float:
        return self.remote_s - (self.sent_s + self.received_s) / 2


@dataclass(frozen=True)
class ClockOffset:
    """The performer's clock minus the conductor's, within ``± error_s``."""

    offset_s: float
    error_s: float  # half the shortest round trip
    round_trips: int

    def describe(self) -> str:
        ahead = "ahead" if self.offset_s >= 0 else "behind"
        return f"{abs(self.offset_s) * 1000:.2f} ms {ahead} (± {self.error_s * 1000:.2f} ms)"


def estimate(samples: Sequence[RoundTrip]) -> ClockOffset:
    best = min(samples, key=lambda s: s.rtt_s)
    return ClockOffset(best.offset_s, best.rtt_s / 2, len(samples))


def measure(
    ask_time: Callable[[], float | None],
    rounds: int = ROUND_TRIPS,
    clock: Callable[[], float] = time.time,
    *,
    within_s: float | None = None,
) -> ClockOffset | None:
    """``rounds`` round trips through ``ask_time`` (the remote clock, None: no answer); with
    ``within_s``, up to ``MORE_ROUND_TRIPS`` more while the estimate ``exceeds`` it. None if
    none was answered."""
    samples = _round_trips(ask_time, rounds, clock)
    if within_s is not None:
        for _ in range(MORE_ROUND_TRIPS):
            if not samples or not exceeds(estimate(samples), within_s):
                break
            samples += _round_trips(ask_time, 1, clock)
    return estimate(samples) if samples else None


def _round_trips(
    ask_time: Callable[[], float | None], rounds: int, clock: Callable[[], float]
) -> list[RoundTrip]:
    samples = []
    for _ in range(rounds):
        sent = clock()
        remote = ask_time()
        received = clock()
        if remote is not None:
            samples.append(RoundTrip(sent, remote, received))
    return samples


def exceeds(offset: ClockOffset, bound_s: float) -> bool:
    """Whether the clocks may differ by more than ``bound_s``: the offset, or its error, is
    over it (a round trip too slow to tell counts as too far)."""
    return abs(offset.offset_s) + offset.error_s > bound_s
