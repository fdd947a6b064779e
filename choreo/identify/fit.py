"""Fitting one servo's figures to what it did, and judging them on moves the fit never saw.

The cost of a candidate is how far, on average over the fit trial, the simulated servo
(``joint_model``) strays outside the position unit each read names (:func:`read_miss_deg`): a read
is a whole unit, so the joint was anywhere within half a unit of it.
The search (``search.minimise``, CMA-ES) starts from the robot file's figures and keeps every
figure inside physical bounds around them. Validation simulates the held-out trial with the
robot file's figures and with the fitted ones: the median and 95th percentile of the error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from choreo.bus.servo_models import DEG_PER_UNIT
from choreo.identify.joint_model import (
    COARSE_STEP_S,
    FIGURES,
    FIT_STEP_S,
    Trial,
    push_of_neighbours,
    reading_error_deg,
    simulate,
    supply_sag,
)
from choreo.identify.search import Cost, minimise
from choreo.preview.actuator import ActuatorParams
from choreo.preview.joint_load import JointLoad

# each figure's bounds: (low, high, scale): "abs" in its own unit, "rel" times the assumed
# figure (searched on a log scale), "stall" times the assumed stall torque
BOUNDS: dict[str, tuple[float, float, str]] = {
    "deadband_deg": (0.0, 2.0, "abs"),
    "backlash_deg": (0.0, 3.0, "abs"),
    "no_load_speed_deg_s": (0.4, 2.0, "rel"),
    "kp_nm_rad": (0.25, 4.0, "rel"),
    "stall_torque_nm": (0.3, 2.0, "rel"),
    "friction_nm": (0.0, 0.15, "stall"),
    "response_delay_s": (0.0, 0.05, "abs"),
    "offset_deg": (-5.0, 5.0, "abs"),
}
# a position read is a whole unit (0.24°): the joint was anywhere within this of what it read.
# BAM's cost, the mean absolute error, takes the read for where the joint was, so a candidate
# that rests where the reads do (at a unit's middle) costs less than the truth, which rests
# anywhere in the unit: on arm6's wrist_pitch the fit bought that with friction and dead band
# (10 hidden truths: friction 3/10 within 15 %, dead band 6/10 within 0.1°; with this cost
# 9/10 and 10/10)
READ_HALF_UNIT_DEG = DEG_PER_UNIT / 2
GENERATIONS = 45
POPULATION = 24
# searches side by side (search.minimise): on one hidden truth of tonypi's knee a single search
# settled at friction x2.7 and the backlash 0.4° low (cost 0.095°, the truth's 0.084°), another
# found 0.077° and every figure; two cost 15 % more CPU than one (4.6 s against 4.0 s a fit: the
# joint model steps a generation of 48 candidates for 9-15 % more than one of 24)
STARTS = 2


@dataclass(frozen=True)
class Validation:
    """Held-out error (degrees) of the assumed figures and of the fitted ones."""

    default_median_deg: float
    default_p95_deg: float
    fitted_median_deg: float
    fitted_p95_deg: float
    reads: int

    @property
    def improvement(self) -> float:
        """How much of the assumed figures' median error the fitted ones remove (0..1)."""
        if self.default_median_deg <= 0:
            return 0.0
        return 1 - self.fitted_median_deg / self.default_median_deg


@dataclass(frozen=True)
class Fitted:
    figures: dict[str, float]  # at the supply measured (as the servo really ran)
    fit_error_deg: float  # on the fit trial, the mean miss of the reads' units (read_miss_deg)
    evaluations: int
    supply_sag_per_nm: float = 0.0  # the supply's sag the fit took (joint_model.supply_sag)


def assumed_figures(params: ActuatorParams) -> dict[str, float]:
    """The figures the joint model takes, from the preview's actuator parameters."""
    return {name: float(getattr(params, name)) for name in FIGURES}


def at_supply(figures: dict[str, float], from_v: float, to_v: float) -> dict[str, float]:
    """Figures that scale with the supply (stall torque, gain, speed) moved from one supply to
    another, as the preview scales them."""
    scaled = dict(figures)
    for name in ("stall_torque_nm", "kp_nm_rad", "no_load_speed_deg_s"):
        scaled[name] = figures[name] * to_v / from_v
    return scaled


def fit_servo(
    trial: Trial,
    load: JointLoad,
    assumed: dict[str, float],
    *,
    with_offset: bool = False,
    seed: int = 0,
    generations: int = GENERATIONS,
) -> Fitted:
    """The figures that make the joint model read as ``trial`` did, searched around
    ``assumed`` (at the supply the trial ran at); the offset only ``with_offset`` (a drop)."""
    names = [name for name in FIGURES if with_offset or name != "offset_deg"]
    low, high, logs = _box(names, assumed)
    # what the neighbours do, once per step size (the same for every candidate)
    pushed = {
        step_s: push_of_neighbours(trial, load, step_s) for step_s in (COARSE_STEP_S, FIT_STEP_S)
    }
    sag = supply_sag(trial, load, assumed, pushed[COARSE_STEP_S])

    def decode(points: np.ndarray) -> dict[str, np.ndarray]:
        values = low + points * (high - low)
        values = np.where(logs, np.exp(values), values)
        figures = {name: values[:, i] for i, name in enumerate(names)}
        if not with_offset:
            figures["offset_deg"] = np.zeros(len(points))
        return figures

    def cost_at(step_s: float) -> Cost:
        def cost(points: np.ndarray) -> np.ndarray:
            figures = decode(points)
            predicted = simulate(
                trial, load, figures, dt_s=step_s, supply_sag_per_nm=sag, pushed=pushed[step_s]
            )
            return read_miss_deg(trial, predicted)

        return cost

    start_values = np.array([assumed[name] for name in names])
    start_values = np.where(logs, np.log(np.maximum(start_values, 1e-12)), start_values)
    start = np.clip((start_values - low) / (high - low), 0, 1)
    # the valley found with the coarse step, the last third of the search on the fine one
    found = minimise(
        cost_at(COARSE_STEP_S),
        start,
        generations=generations,
        population=POPULATION,
        seed=seed,
        refine=(cost_at(FIT_STEP_S), max(1, generations // 3)),
        starts=STARTS,
    )
    best = decode(found.best[None])
    figures = {name: float(best[name][0]) for name in FIGURES}
    return Fitted(figures, found.cost, found.evaluations, sag)


def read_miss_deg(trial: Trial, predicted_deg: np.ndarray) -> np.ndarray:
    """Each candidate's mean miss of the reads (``predicted_deg``: (reads, k) degrees, as
    ``simulate`` gives): how far its angle lies outside the half unit around each read, 0
    within it."""
    outside = reading_error_deg(trial, predicted_deg) - READ_HALF_UNIT_DEG
    return np.mean(np.maximum(outside, 0.0), axis=0)


def validate(
    trial: Trial,
    load: JointLoad,
    assumed: dict[str, float],
    fitted: dict[str, float],
    supply_sag_per_nm: float = 0.0,
) -> Validation:
    """The held-out trial simulated with the assumed and the fitted figures (the supply
    sagging as the fit took it)."""
    both = {name: np.array([assumed[name], fitted[name]]) for name in FIGURES}
    predicted = simulate(trial, load, both, supply_sag_per_nm=supply_sag_per_nm)
    errors = reading_error_deg(trial, predicted)
    median, p95 = np.median(errors, axis=0), np.percentile(errors, 95, axis=0)
    return Validation(
        float(median[0]), float(p95[0]), float(median[1]), float(p95[1]), len(trial.read_deg)
    )


def _box(names: list[str], assumed: dict[str, float]) -> tuple[np.ndarray, ...]:
    low, high, logs = [], [], []
    for name in names:
        a, b, scale = BOUNDS[name]
        if scale == "rel":
            low.append(math.log(a * assumed[name]))
            high.append(math.log(b * assumed[name]))
        elif scale == "stall":
            low.append(a * assumed["stall_torque_nm"])
            high.append(b * assumed["stall_torque_nm"])
        else:
            low.append(a)
            high.append(b)
        logs.append(scale == "rel")
    return np.array(low), np.array(high), np.array(logs)
