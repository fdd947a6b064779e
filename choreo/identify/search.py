"""A small CMA-ES (Hansen's covariance matrix adaptation evolution strategy) in numpy: the search
for the figures that make the simulated servo read as the real one did.

BAM fits its actuator models with CMA-ES too. This one is the textbook algorithm ("The CMA
Evolution Strategy: A Tutorial", Hansen 2016, with its default settings) on a box: the search
runs in [0, 1]^n, where every figure is scaled between its bounds, and a candidate outside the box
is evaluated at its nearest point inside, plus a penalty for the distance. The cost function
takes a whole generation at once (rows are candidates), which is what makes the joint model fast;
several searches from one start (``starts``) are costed together in that one call, so a second
one, which may miss a false valley the first falls into, costs little more.
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
    refine: tuple[Cost, int] | None = None,
    starts: int = 1,
) -> Found:
    """The point of [0, 1]^n where ``cost`` is lowest, searched from ``start``. ``refine``: a
    finer (dearer) cost and how many generations it takes over for, from where the search
    stands: the best is then the best that cost found. ``starts``: searches run side by side
    from ``start``, each on its own random draws, their candidates costed in one call (a valley
    one of them falls into, the others may not); the best is the best any of them found."""
    settings = _Settings.of(len(start), population)
    mean = np.clip(np.asarray(start, dtype=float), 0, 1)
    searches = [_Search(seed + i, mean, sigma) for i in range(starts)]
    phases = [(cost, generations)] if refine is None else [(cost, generations - refine[1]), refine]
    evaluations, generation = 0, 0
    for phase_cost, count in phases:
        bests = np.array([search.best for search in searches])
        judged = _penalised(phase_cost, bests)  # judged anew by this phase's cost
        evaluations += len(searches)
        for search, judged_cost in zip(searches, judged):
            search.best_cost = float(judged_cost)
        running = list(searches)
        for _ in range(max(count, 0)):
            generation += 1
            steps = [search.state.sample(search.rng, settings.lam) for search in running]
            points = np.concatenate(
                [s.state.mean + s.state.sigma * d for s, d in zip(running, steps)]
            )
            costs = _penalised(phase_cost, points).reshape(len(running), settings.lam)
            evaluations += len(points)
            for search, step, point, cost_of in zip(
                running, steps, np.split(points, len(running)), costs
            ):
                search.take(settings, step, point, cost_of, generation)
            running = [search for search in running if search.state.spread >= tolerance]
            if not running:
                break
    winner = min(searches, key=lambda search: search.best_cost)
    return Found(winner.best, winner.best_cost, evaluations, generation)


class _Search:
    """One CMA-ES search: its random draws, its distribution, and the best point it found."""

    def __init__(self, seed: int, mean: np.ndarray, sigma: float):
        self.rng = np.random.default_rng(seed)
        self.state = _State.at(mean, sigma)
        self.best, self.best_cost = mean.copy(), np.inf

    def take(
        self,
        settings: _Settings,
        steps: np.ndarray,
        points: np.ndarray,
        costs: np.ndarray,
        generation: int,
    ) -> None:
        """One generation's candidates (``steps`` from the mean, ``points``) and their costs."""
        order = np.argsort(costs)
        if costs[order[0]] < self.best_cost:
            self.best, self.best_cost = np.clip(points[order[0]], 0, 1), float(costs[order[0]])
        self.state.adapt(settings, steps[order[: settings.mu]], generation)


@dataclass(frozen=True)
class _Settings:
    """The tutorial's default learning rates for ``n`` dimensions and ``lam`` candidates per
    generation (Hansen 2016, table 1), of which the best ``mu`` move the mean."""

    n: int
    lam: int
    mu: int
    weights: np.ndarray
    mu_eff: float
    c_sigma: float
    d_sigma: float
    c_c: float
    c_1: float
    c_mu: float
    chi_n: float  # the expected length of an n-dimensional standard normal vector

    @classmethod
    def of(cls, n: int, population: int | None) -> _Settings:
        lam = population or 4 + int(3 * np.log(n))
        mu = lam // 2
        weights = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
        weights /= weights.sum()
        mu_eff = float(1 / np.sum(weights**2))
        c_sigma = (mu_eff + 2) / (n + mu_eff + 5)
        c_1 = 2 / ((n + 1.3) ** 2 + mu_eff)
        return cls(
            n=n,
            lam=lam,
            mu=mu,
            weights=weights,
            mu_eff=mu_eff,
            c_sigma=c_sigma,
            d_sigma=1 + 2 * max(0.0, np.sqrt((mu_eff - 1) / (n + 1)) - 1) + c_sigma,
            c_c=(4 + mu_eff / n) / (n + 4 + 2 * mu_eff / n),
            c_1=c_1,
            c_mu=min(1 - c_1, 2 * (mu_eff - 2 + 1 / mu_eff) / ((n + 2) ** 2 + mu_eff)),
            chi_n=float(np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))),
        )


@dataclass
class _State:
    """The search distribution: its mean, step size, covariance (as its eigen decomposition,
    refreshed after each update) and the two evolution paths."""

    mean: np.ndarray
    sigma: float
    cov: np.ndarray
    p_sigma: np.ndarray
    p_c: np.ndarray
    values: np.ndarray
    vectors: np.ndarray

    @classmethod
    def at(cls, mean: np.ndarray, sigma: float) -> _State:
        n = len(mean)
        return cls(mean, sigma, np.eye(n), np.zeros(n), np.zeros(n), np.ones(n), np.eye(n))

    @property
    def scale(self) -> np.ndarray:
        return np.sqrt(np.maximum(self.values, 1e-20))

    @property
    def spread(self) -> float:
        """The largest standard deviation of the next candidates: the search has converged
        when it is below the tolerance."""
        return float(self.sigma * np.sqrt(self.values.max()))

    def sample(self, rng: np.random.Generator, lam: int) -> np.ndarray:
        """``lam`` steps from the mean (before ``sigma``), drawn from the covariance."""
        z = rng.standard_normal((lam, len(self.mean)))
        return (z * self.scale) @ self.vectors.T

    def adapt(self, s: _Settings, chosen: np.ndarray, generation: int) -> None:
        """Move the mean to the weighted best ``chosen`` steps, then adapt the paths, the
        covariance (rank one and rank mu) and the step size."""
        step_mean = s.weights @ chosen
        self.mean = self.mean + self.sigma * step_mean
        inverse_sqrt = self.vectors @ np.diag(1 / self.scale) @ self.vectors.T
        self.p_sigma = (1 - s.c_sigma) * self.p_sigma + np.sqrt(
            s.c_sigma * (2 - s.c_sigma) * s.mu_eff
        ) * (inverse_sqrt @ step_mean)
        stalled = np.linalg.norm(self.p_sigma) / np.sqrt(1 - (1 - s.c_sigma) ** (2 * generation))
        h_sigma = float(stalled < (1.4 + 2 / (s.n + 1)) * s.chi_n)
        self.p_c = (1 - s.c_c) * self.p_c + h_sigma * np.sqrt(
            s.c_c * (2 - s.c_c) * s.mu_eff
        ) * step_mean
        rank_mu = (chosen.T * s.weights) @ chosen
        self.cov = (
            (1 - s.c_1 - s.c_mu) * self.cov
            + s.c_1
            * (np.outer(self.p_c, self.p_c) + (1 - h_sigma) * s.c_c * (2 - s.c_c) * self.cov)
            + s.c_mu * rank_mu
        )
        self.sigma *= np.exp((s.c_sigma / s.d_sigma) * (np.linalg.norm(self.p_sigma) / s.chi_n - 1))
        self.values, self.vectors = np.linalg.eigh(self.cov)


def _penalised(cost: Cost, points: np.ndarray) -> np.ndarray:
    inside = np.clip(points, 0, 1)
    return cost(inside) + np.sum((points - inside) ** 2, axis=1)
