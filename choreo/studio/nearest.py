"""The nearest time that works for an edit that would not plan where it was asked: a keyframe
added or moved too soon after (or before) another.

The search stays within a budget of plans, whatever the motion's length: the planner, allowed
to stretch, names where it would put the keyframe (one plan, and most often the answer); then
the grid of times every NEAREST_STEP_S either side, between the keyframes either side, is tried
nearest first when there are few enough, else bisected on each side (a time farther from a
keyframe too near works if a nearer one does). Candidates are checked by the planner alone;
the time named is checked as the write would be.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from choreo.errors import ChoreoError
from choreo.plan.planner import plan_motion
from choreo.studio import trial
from choreo.studio.yaml_edit import EditRefused

NEAREST_STEP_S = 0.05  # the times tried instead of one that does not plan: this far apart
NEAREST_SPAN_S = 1.0  # and at most this far either side
NEAREST_PLANS = 10  # plans a search makes at most (one of a 5-minute motion: about 0.2 s)
STANDS_S = 0.005  # a time this near a neighbour stands on it (half the timeline's 0.01 s step)


@dataclass(frozen=True)
class Search:
    """Where an edit works (None: nowhere tried), which times were tried, and how many plans
    that took."""

    works: float | None
    tried: tuple[float, ...]
    plans: int

    def hint(self) -> str:
        if self.works is not None:
            return f"the nearest time that works is {self.works:.2f} s"
        if self.tried:
            count = len(set(self.tried))
            return (
                f"none of the {count} time{'s' * (count != 1)} tried from "
                f"{min(self.tried):.2f} to {max(self.tried):.2f} s works"
            )
        return "no other time between its neighbours to try"


class _Budget:
    """The plans a search may still make, and the times it tried."""

    def __init__(self, path: Path, text_at: Callable[[float], str]):
        self.path, self.text_at = path, text_at
        self.left = NEAREST_PLANS
        self.tried: list[float] = []

    def works(self, t_s: float, *, checked: bool = False) -> bool:
        """Whether the edit plans at ``t_s`` (``checked``: as the write would be checked)."""
        self.left -= 1
        self.tried.append(t_s)
        try:
            text = self.text_at(t_s)
        except EditRefused:
            return False
        if not checked:
            return trial.plans(self.path, text)
        try:
            trial.check_plans(self.path, text)
        except ChoreoError:
            return False
        return True


def nearest_time(
    path: Path,
    text: str,
    t_s: float,
    text_at: Callable[[float], str],
    window: tuple[float, float],
    line: int | None,
) -> Search:
    """The time nearest ``t_s`` within ``window`` (the neighbours' times) where the edit,
    written as ``text_at(time)`` gives it (``text`` at ``t_s``, its keyframe at ``line``),
    would plan."""
    budget = _Budget(path, text_at)
    low, high = window[0] + STANDS_S, window[1] - STANDS_S
    hinted = _stretched(path, text, t_s, line)
    budget.left -= 1  # the stretched plan
    if hinted is not None and budget.works(hinted, checked=True):  # past the last one too
        return Search(hinted, tuple(budget.tried), NEAREST_PLANS - budget.left)
    steps = int(round(NEAREST_SPAN_S / NEAREST_STEP_S))
    later = [round(t_s + k * NEAREST_STEP_S, 6) for k in range(1, steps + 1)]
    earlier = [round(t_s - k * NEAREST_STEP_S, 6) for k in range(1, steps + 1)]
    sides = [[t for t in side if low < t < high and t != hinted] for side in (later, earlier)]
    few = sum(map(len, sides)) < budget.left
    found = _scan(budget, sides) if few else _bisect(budget, sides)
    while found is not None and not budget.works(found, checked=True):  # a plan kept for it
        sides = [[t for t in side if abs(t - t_s) > abs(found - t_s)] for side in sides]
        found = _scan(budget, sides)  # the planner passed it but the page's check did not
    return Search(found, tuple(budget.tried), NEAREST_PLANS - budget.left)


def _stretched(path: Path, text: str, t_s: float, line: int | None) -> float | None:
    """Where the planner, allowed to stretch, would put the keyframe at ``line`` (on the
    grid); None if it does not move it or the file does not load."""
    try:
        stretched = plan_motion(trial.check_loads(path, text), stretch=True)
    except ChoreoError:
        return None
    shifts = [s.shift_s for s in stretched.stretches if s.where.line == line]
    if not shifts:
        return None
    return float(np.ceil((t_s + shifts[0]) / NEAREST_STEP_S - 1e-6) * NEAREST_STEP_S)


def _scan(budget: _Budget, sides: list[list[float]]) -> float | None:
    """Every time of ``sides`` (each nearest first), nearest first, while the budget lasts
    (keeping one plan to check the time found)."""
    nearest_first = sorted((t for side in sides for t in side), key=lambda t: _rank(sides, t))
    for t in nearest_first:
        if budget.left <= 1:  # the last plan checks the time found
            return None
        if budget.works(t):
            return t
    return None


def _rank(sides: list[list[float]], t_s: float) -> tuple[int, int]:
    """``t_s``'s place in a nearest-first order of both sides: its step, later first."""
    for number, side in enumerate(sides):
        if t_s in side:
            return side.index(t_s), number
    return len(max(sides, key=len)), len(sides)


def _bisect(budget: _Budget, sides: list[list[float]]) -> float | None:
    """Per side (nearest first), the nearest time that works, found by bisection: if the
    farthest fails, none on that side is taken to. A side is searched only nearer than what
    the other found."""
    best: float | None = None
    for side in sides:
        if best is not None:
            side = side[: _rank(sides, best)[0]]
        if not side or budget.left <= 1 or not budget.works(side[-1]):
            continue
        failing, working = -1, len(side) - 1  # side[working] works; "before" side[0]: t_s fails
        while working - failing > 1 and budget.left > 1:  # the last plan checks the time found
            middle = (failing + working) // 2
            if budget.works(side[middle]):
                working = middle
            else:
                failing = middle
        best = side[working]
    return best
