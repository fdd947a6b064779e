"""Keyframe timing rules: when each keyframe asks to be reached, as played.

One home for what ``t``, ``after``, ``hold``, ``repeat`` and ``speed`` mean (the loader's "t goes
backwards" check, the planner and the action-group export all read them here):

- ``t``: the arrival time counted from the motion start (the first repetition) or from the
  repetition's first keyframe (later repetitions keep the file's spacing of ``t`` values);
- ``after``: a delay after the previous keyframe is left (reached, then held);
- neither: as soon as the limits allow (the planner decides; estimates here take a callback);
- the first keyframe: the start waits for its ``t`` (or ``after``); when ``repeat`` wraps back to
  it, it is reached ``after`` the last keyframe is left, or as soon as possible;
- with a ``repetition_at`` clock (a motion with music), later repetitions' first keyframe and
  ``t`` keyframes are at the clock's times instead: the song's beats, not the first repetition's
  spacing;
- ``hold``: stay this long once reached; ``speed``: every time divided by it.

All times here are played seconds (speed applied). Keyframes are anything with ``t_s``,
``after_s``, ``hold_s`` and ``stop`` (motion keyframes, the loader's steps, generated ones).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

import numpy as np

from choreo.core.arguments import Range


class TimedKeyframe(Protocol):
    """What the timing rules read of a keyframe (times in the file's seconds)."""

    @property
    def t_s(self) -> float | None: ...

    @property
    def after_s(self) -> float | None: ...

    @property
    def hold_s(self) -> float: ...

    @property
    def stop(self) -> bool: ...


K = TypeVar("K", bound=TimedKeyframe)

# The longest time a file may write (t, after, hold, a gait's period): a day. Far beyond any
# dance (at most 300 s between keyframes is planned; a longer pause is a hold), and far from the
# numbers (1.0e+308) whose sums overflow to infinity on the way to the planner.
MAX_TIME_S = 86_400.0
# The time scale (a file's speed, --speed): beyond these a motion is a still or a blur, and its
# times (t / speed) overflow.
MIN_SPEED, MAX_SPEED = 0.01, 100.0
SPEED = Range(at_least=MIN_SPEED, at_most=MAX_SPEED)  # a motion's speed, and --speed


class Timing(enum.Enum):
    ASAP = enum.auto()  # as soon as the limits allow
    AFTER = enum.auto()  # a delay after the previous keyframe is left
    AT = enum.auto()  # a time after an anchor (the motion start, or the repetition's first)


@dataclass(frozen=True)
class PlayedKeyframe(Generic[K]):
    """A keyframe as played: repeat unrolled, speed applied (all times in played seconds)."""

    keyframe: K
    timing: Timing
    value_s: float  # AFTER: the delay; AT: the time after the anchor; ASAP: 0
    anchor: int | None  # AT: the played index whose arrival t counts from; None: the start
    hold_s: float
    rests: bool  # velocity zero here: stop, hold, or an end of the whole play
    speed: float


def played_keyframes(
    keyframes: Sequence[K],
    *,
    repeat: int = 1,
    speed: float = 1.0,
    repetition_at: Callable[[float, int], float] | None = None,
) -> list[PlayedKeyframe[K]]:
    """The keyframes in playing order; a keyframe rests if it says stop or hold, and so do the
    very first and the very last (not the ends of inner repetitions: the wrap flows).
    ``repetition_at(t_s, rep)``: the motion time of file time ``t_s`` in repetition ``rep``."""
    if not keyframes:
        return []
    first = keyframes[0]
    origin_s = first.t_s if first.t_s is not None else first.after_s or 0.0
    played: list[PlayedKeyframe[K]] = []
    for rep in range(repeat):
        anchor = None if rep == 0 or repetition_at else len(played)
        for index, kf in enumerate(keyframes):
            timing, value_s = _timing_of(kf, index == 0, rep, origin_s)
            written_s = origin_s if index == 0 else kf.t_s
            if rep and repetition_at and written_s is not None:
                timing, value_s = Timing.AT, repetition_at(written_s, rep)
            last = rep == repeat - 1 and index == len(keyframes) - 1
            played.append(
                PlayedKeyframe(
                    kf,
                    timing,
                    value_s / speed,
                    anchor if timing is Timing.AT else None,
                    kf.hold_s / speed,
                    rests=kf.stop or kf.hold_s > 0 or not played or last,
                    speed=speed,
                )
            )
    return played


def _timing_of(kf: TimedKeyframe, first: bool, rep: int, origin_s: float) -> tuple[Timing, float]:
    """(timing, value in the file's seconds) of one keyframe of repetition ``rep``."""
    if first:
        # The start waits for the first keyframe's time; a wrap reaches it again after its
        # `after`, or as soon as the limits allow.
        if rep == 0:
            return Timing.AT, origin_s
        return (Timing.AFTER, kf.after_s) if kf.after_s is not None else (Timing.ASAP, 0.0)
    if kf.t_s is not None:
        return Timing.AT, kf.t_s if rep == 0 else kf.t_s - origin_s
    if kf.after_s is not None:
        return Timing.AFTER, kf.after_s
    return Timing.ASAP, 0.0


def wanted_arrival_s(
    played: Sequence[PlayedKeyframe],
    i: int,
    arrivals_s: Sequence[float] | np.ndarray,
    shifts_s: np.ndarray | None = None,
) -> float | None:
    """When keyframe ``i`` asks to be reached, given the arrivals of the ones before it; None
    for as soon as possible. ``shifts_s``: how much later than asked each keyframe was reached
    (stretching): t values move with the earlier shifts of their repetition."""
    p = played[i]
    if p.timing is Timing.ASAP:
        return None
    if p.timing is Timing.AFTER:
        return arrivals_s[i - 1] + played[i - 1].hold_s + p.value_s
    start = 0.0 if p.anchor is None else arrivals_s[p.anchor]
    shifted = 0.0 if shifts_s is None else float(np.sum(shifts_s[(p.anchor or 0) + 1 : i]))
    return start + p.value_s + shifted


def estimated_arrivals_s(
    played: Sequence[PlayedKeyframe], move_s: Callable[[int], float] = lambda i: 0.0
) -> np.ndarray:
    """Arrival times as if every timing were met; a keyframe timed "as soon as possible", or
    asking for a time before the previous one is left, is reached ``move_s(i)`` after that."""
    arrive = np.zeros(len(played))
    for i in range(len(played)):
        wanted = wanted_arrival_s(played, i, arrive)
        if i == 0:
            arrive[0] = wanted or 0.0
            continue
        leave = arrive[i - 1] + played[i - 1].hold_s
        arrive[i] = wanted if wanted is not None and wanted > leave else leave + move_s(i)
    return arrive


def known_arrivals_s(played: Sequence[PlayedKeyframe]) -> list[float | None]:
    """Arrival times the keyframes' own ``t`` and ``after`` fix, nothing planned: ``None`` for a
    keyframe timed "as soon as possible" and for those counting from one."""
    arrive: list[float | None] = []
    # The same with NaN for None: wanted_arrival_s only reads the arrival that keyframe i counts
    # from, which the test just before has found known.
    known_s: list[float] = []
    for i, p in enumerate(played):
        counts_from = i - 1 if p.timing is Timing.AFTER else p.anchor
        arrival = None
        if p.timing is not Timing.ASAP and (counts_from is None or arrive[counts_from] is not None):
            arrival = wanted_arrival_s(played, i, known_s)
        arrive.append(arrival)
        known_s.append(math.nan if arrival is None else arrival)
    return arrive


@dataclass(frozen=True)
class BackwardTime:
    """A keyframe whose ``t`` is not after the earliest time the keyframe before can be left."""

    index: int
    t_s: float  # the time it asks for (played seconds)
    earliest_leave_s: float  # when the keyframe before it can be left, at the earliest


def backward_times(played: Sequence[PlayedKeyframe]) -> list[BackwardTime]:
    """Every keyframe after the first whose ``t`` is not later than the keyframe before it can
    be left (keyframes timed "as soon as possible" counted as taking no time)."""
    if not played:
        return []
    arrive = estimated_arrivals_s(played)
    backward = []
    for i in range(1, len(played)):
        leave_s = float(arrive[i - 1] + played[i - 1].hold_s)
        wanted = wanted_arrival_s(played, i, arrive)
        if played[i].timing is Timing.AT and wanted is not None and wanted <= leave_s:
            backward.append(BackwardTime(i, wanted, leave_s))
    return backward
