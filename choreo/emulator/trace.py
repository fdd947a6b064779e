"""Where the emulated servos really went: their paths rebuilt from the wire log's move starts
(servo IDs and units only: ``choreo.play.path_errors`` reads them through a robot's joints)."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from choreo.emulator.emulated_servo import StartedMove


def executed_units(
    moves: Iterable[StartedMove], servo_id: int, start_units: float, times_s: np.ndarray
) -> np.ndarray:
    """Position (POS_READ units) of one servo at ``times_s``, from its logged linear moves.

    A move runs from ``from_units`` to ``to_units`` over ``duration_s``; a later move starts from
    wherever the servo then is (the log records that), so the path is piecewise linear.
    """
    own = sorted((m for m in moves if m.servo_id == servo_id), key=lambda m: m.time_s)
    times_s = np.asarray(times_s, dtype=float)
    if not own:
        return np.full(times_s.shape, float(start_units))
    starts = np.array([m.time_s for m in own])
    index = np.searchsorted(starts, times_s, side="right") - 1
    before = index < 0
    index = np.clip(index, 0, None)
    begin = np.array([m.from_units for m in own])[index]
    end = np.array([m.to_units for m in own])[index]
    duration = np.array([m.duration_s for m in own])[index]
    fraction = np.where(
        duration > 0, (times_s - starts[index]) / np.where(duration > 0, duration, 1), 1.0
    )
    path = begin + (end - begin) * np.clip(fraction, 0.0, 1.0)
    return np.where(before, float(start_units), path)


def start_skew_ms(
    moves: Iterable[StartedMove],
    since_s: float = -math.inf,
    until_s: float = math.inf,
    group_gap_s: float = 0.005,
) -> float:
    """The largest first-to-last spread of move starts within one burst (starts less than
    ``group_gap_s`` after the previous one), between ``since_s`` and ``until_s``: 0 when every
    tick starts all its servos at once, the forwarding time when they start one after another."""
    times = sorted(m.time_s for m in moves if since_s <= m.time_s <= until_s)
    skew_s, group_start_s, last_s = 0.0, -math.inf, -math.inf
    for time_s in times:
        if time_s - last_s > group_gap_s:
            group_start_s = time_s
        skew_s = max(skew_s, time_s - group_start_s)
        last_s = time_s
    return skew_s * 1000
