"""The small CMA-ES: it finds the bottom of a badly scaled bowl, inside the box."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.identify.search import minimise


def test_it_finds_the_minimum_of_a_badly_scaled_bowl():
    bottom = np.array([0.3, 0.7, 0.1, 0.9])
    scales = np.array([1.0, 10.0, 100.0, 3.0])
    found = minimise(
        lambda p: np.sum((p - bottom) ** 2 * scales, axis=1), np.full(4, 0.5), generations=200
    )
    assert found.best == pytest.approx(bottom, abs=1e-3)
    assert found.evaluations > found.generations


def test_a_minimum_outside_the_box_is_found_on_its_edge():
    found = minimise(lambda p: np.sum((p - 1.5) ** 2, axis=1), np.full(2, 0.5), generations=150)
    assert found.best == pytest.approx([1.0, 1.0], abs=1e-3)
    assert np.all(found.best <= 1.0)


def test_the_same_seed_gives_the_same_answer():
    cost = lambda p: np.sum(np.abs(p - 0.2), axis=1)  # noqa: E731
    first = minimise(cost, np.full(3, 0.6), generations=20, seed=4)
    again = minimise(cost, np.full(3, 0.6), generations=20, seed=4)
    assert np.array_equal(first.best, again.best)


def test_a_finer_cost_takes_over_for_the_last_generations_and_judges_the_best():
    coarse_bottom, fine_bottom = np.array([0.3, 0.6]), np.array([0.32, 0.58])
    calls = {"coarse": 0, "fine": 0}

    def bowl(bottom: np.ndarray, name: str):
        def cost(p: np.ndarray) -> np.ndarray:
            calls[name] += 1
            return np.sum((p - bottom) ** 2, axis=1)

        return cost

    found = minimise(
        bowl(coarse_bottom, "coarse"),
        np.full(2, 0.5),
        generations=90,
        refine=(bowl(fine_bottom, "fine"), 30),
    )
    assert found.best == pytest.approx(fine_bottom, abs=2e-3)
    assert found.cost == pytest.approx(np.sum((found.best - fine_bottom) ** 2))
    assert calls["coarse"] > calls["fine"] > 1  # the fine one for its third of the generations


def two_valleys(p: np.ndarray) -> np.ndarray:
    """A shallow valley by the start and a deeper one further off."""
    near = np.sum((p - np.array([0.3, 0.3])) ** 2, axis=1) + 0.01
    far = np.sum((p - np.array([0.8, 0.75])) ** 2, axis=1)
    return np.minimum(near, far)


def test_searches_side_by_side_keep_the_deepest_valley_any_of_them_found():
    alone = [minimise(two_valleys, np.full(2, 0.3), generations=40, seed=s) for s in (4, 5, 6)]
    assert [found.cost > 0.009 for found in alone] == [True, True, False]  # one found the far
    together = minimise(two_valleys, np.full(2, 0.3), generations=40, seed=4, starts=3)
    assert together.best == pytest.approx([0.8, 0.75], abs=1e-3)
    assert together.cost == alone[2].cost  # each search is the one its seed runs alone
    assert together.evaluations == sum(found.evaluations for found in alone)


def test_searches_side_by_side_cost_their_candidates_in_one_call():
    rows = []

    def cost(p: np.ndarray) -> np.ndarray:
        rows.append(len(p))
        return np.sum((p - 0.4) ** 2, axis=1)

    minimise(cost, np.full(3, 0.5), generations=5, population=8, starts=2, tolerance=0)
    assert rows == [2] + [16] * 5  # the two starts judged, then each generation's candidates
    rows.clear()  # a finer cost judges both bests anew and refines both
    minimise(cost, np.full(3, 0.5), generations=5, population=8, starts=2, refine=(cost, 2))
    assert rows == [2] + [16] * 3 + [2] + [16] * 2
