"""Helpers for the preview's tests: their data, straight moves as ticks, the tick at a time."""

from __future__ import annotations

import numpy as np
import paths

from choreo.plan.ticks import Tick

DATA = paths.DATA / "preview"
MOTIONS = DATA / "motions"


def linear_ticks(robot, start_deg, end_deg, duration_ms: int, tick_ms: int) -> list[Tick]:
    """A straight move in equal ticks, every servo staged every tick."""
    start_deg, end_deg = np.asarray(start_deg, float), np.asarray(end_deg, float)
    ticks = []
    for k in range(1, duration_ms // tick_ms + 1):
        angles = start_deg + (end_deg - start_deg) * k * tick_ms / duration_ms
        units = tuple(int(round(j.to_units(a))) for j, a in zip(robot.joints, angles))
        ticks.append(Tick((k - 1) * tick_ms, tick_ms, units, (True,) * len(units)))
    return ticks


def tick_at(ticks, t_s: float) -> Tick:
    """The tick running at ``t_s``."""
    return next(tick for tick in ticks if tick.start_ms / 1000 <= t_s < tick.end_ms / 1000)
