"""A small CMA-ES (Hansen's covariance matrix adaptation evolution strategy) in numpy: the search
for the figures that make the simulated servo read as the real one did.

BAM fits its actuator models with CMA-ES too. This one is the textbook algorithm ("The CMA
Evolution Strategy: A Tutorial", Hansen 2016, with its default settings) on a box: the search
runs in [0, 1]^n, where every figure is scaled between its bounds, and a candidate outside the box
is evaluated at its nearest point inside, plus a penalty for the distance. The cost function
takes a whole generation at once (rows are candidates), which is what makes the joint model fast.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Cost = Callable[[np.ndarray], np.ndarray]  # (k, n) points in [0, 1] -> (k,) costs


@dataclass(frozen=True)
class Found:
    best: np.ndarray  # in [0, 1]^n
    cost: float
    evaluations: int
    generations: int


def minimise(
    cost: Cost,
    start: np.ndarray,
    *,
    sigma: float = 0.25,
    generations: int = 60,
    population: int | None = None,
    seed: int = 0,
    tolerance: float = 1e-4,
) -> Found:
    """The point of [0, 1]^n where ``cost`` is lowest, searched from ``start``."""
    rng = np.random.default_rng(seed)
    n = len(start)
    lam = population or 4 + int(3 * np.log(n))
    mu = lam // 2
    weights = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
    weights /= weights.sum()
    mu_eff = 1 / np.sum(weights**2)
    c_sigma = (mu_eff + 2) / (n + mu_eff + 5)
    d_sigma = 1 + 2 * max(0.0, np.sqrt((mu_eff - 1) / (n + 1)) - 1) + c_sigma
    c_c = (4 + mu_eff / n) / (n + 4 + 2 * mu_eff / n)
    c_1 = 2 / ((n + 1.3) ** 2 + mu_eff)
    c_mu = min(1 - c_1, 2 * (mu_eff - 2 + 1 / mu_eff) / ((n + 2) ** 2 + mu_eff))
    chi_n = np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))

    mean = np.clip(np.asarray(start, dtype=float), 0, 1)
    p_sigma, p_c = np.zeros(n), np.zeros(n)
    cov = np.eye(n)
    best, best_cost, evaluations = mean.copy(), float(_penalised(cost, mean[None])[0]), 1
    generation = 0
    for generation in range(1, generations + 1):  # noqa: B007 (reported)
        values, vectors = np.linalg.eigh(cov)
        scale = np.sqrt(np.maximum(values, 1e-20))
        z = rng.standard_normal((lam, n))
        steps = (z * scale) @ vectors.T
        points = mean + sigma * steps
        costs = _penalised(cost, points)
        evaluations += lam
        order = np.argsort(costs)
        if costs[order[0]] < best_cost:
            best, best_cost = np.clip(points[order[0]], 0, 1), float(costs[order[0]])
        chosen = steps[order[:mu]]
        step_mean = weights @ chosen
        mean = mean + sigma * step_mean
        inverse_sqrt = vectors @ np.diag(1 / scale) @ vectors.T
        p_sigma = (1 - c_sigma) * p_sigma + np.sqrt(c_sigma * (2 - c_sigma) * mu_eff) * (
            inverse_sqrt @ step_mean
        )
        stalled = np.linalg.norm(p_sigma) / np.sqrt(1 - (1 - c_sigma) ** (2 * generation))
        h_sigma = float(stalled < (1.4 + 2 / (n + 1)) * chi_n)
        p_c = (1 - c_c) * p_c + h_sigma * np.sqrt(c_c * (2 - c_c) * mu_eff) * step_mean
        rank_mu = (chosen.T * weights) @ chosen
        cov = (
            (1 - c_1 - c_mu) * cov
            + c_1 * (np.outer(p_c, p_c) + (1 - h_sigma) * c_c * (2 - c_c) * cov)
            + c_mu * rank_mu
        )
        sigma *= np.exp((c_sigma / d_sigma) * (np.linalg.norm(p_sigma) / chi_n - 1))
        if sigma * np.sqrt(values.max()) < tolerance:
            break
    return Found(best, best_cost, evaluations, generation)


def _penalised(cost: Cost, points: np.ndarray) -> np.ndarray:
    inside = np.clip(points, 0, 1)
    return cost(inside) + np.sum((points - inside) ** 2, axis=1)
