"""Trajectory -> ticks: the servos' own linear moves, staged on the bus and started together.

A servo can only do "move linearly to P over T ms, from wherever you are now". A tick is one
such move for every servo at once: during tick k the player stages tick k+1 with
MOVE_TIME_WAIT_WRITE (only to the servos whose target changes: the others keep their preset,
which survives START, and are already at it) and starts it with one broadcast MOVE_START.

Ticks are chosen greedily, each as long as it can be (farthest reach): every joint's chord over
the tick must stay within ``tolerance_deg`` of the smooth trajectory, and no tick may be shorter
than the bus needs to stage the next one. Rounding targets to whole servo units adds at most
half a unit (0.12°) on top.

How the chord is checked, cheaply and without gaps: the trajectory is sampled on a lattice of
``step`` ms; between two samples a curve whose acceleration stays below A leaves the straight
line through them by at most A·step²/8 (the margin), so a chord that stays within
``tolerance - margin`` of the samples stays within ``tolerance`` everywhere. Tick ends are
whole milliseconds: after the lattice search, the milliseconds just past the last lattice point
that fits are tried too.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from .errors import PlanningError
from .planner import Trajectory
from .protocol import SPECS, Command
from .robot import Robot
from .servos import DEG_PER_UNIT, UNITS_PER_DEG

log = logging.getLogger(__name__)

_STAGE = SPECS[Command.MOVE_TIME_WAIT_WRITE]
MOVE_BYTES = _STAGE.request_len + 3  # a whole staged-move packet: 10 bytes
START_BYTES = SPECS[Command.MOVE_START].request_len + 3  # broadcast MOVE_START: 6 bytes
BITS_PER_BYTE = 10  # start + 8 data + stop
POSITION_RANGE_UNITS = next((f.lo, f.hi) for f in _STAGE.request if f.name == "pos_units")
MAX_TICK_MS = next(f.hi for f in _STAGE.request if f.name == "time_ms")
DEFAULT_BUS_MARGIN_MS = 1.5  # slack per tick beyond the wire time (host jitter, START gap)
QUANTIZATION_DEG = DEG_PER_UNIT / 2  # rounding a target to whole units


@dataclass(frozen=True)
class Tick:
    """One synchronized linear move: every servo heads for its target over ``duration_ms``."""

    start_ms: int
    duration_ms: int
    targets_units: tuple[int, ...]  # robot joint order
    staged: tuple[bool, ...]  # target changed: this servo gets a MOVE_TIME_WAIT_WRITE

    @property
    def end_ms(self) -> int:
        return self.start_ms + self.duration_ms

    @property
    def bytes(self) -> int:
        """Bytes on the wire to stage and start this tick; a tick that changes no target sends
        nothing (every servo is already at its target)."""
        return staging_bytes(sum(self.staged))


@dataclass(frozen=True)
class TickPlan:
    ticks: tuple[Tick, ...]
    tolerance_deg: float
    max_deviation_deg: float  # of the servos' piecewise-linear paths from the smooth trajectory
    total_bytes: int
    peak_bus_use: float  # highest share of a tick spent on the wire staging the next (0..1)

    @property
    def duration_ms(self) -> int:
        return self.ticks[-1].end_ms if self.ticks else 0


def staging_bytes(n_staged: int) -> int:
    return n_staged * MOVE_BYTES + START_BYTES if n_staged else 0


def wire_time_ms(n_bytes: int, baudrate: int) -> float:
    return n_bytes * BITS_PER_BYTE / baudrate * 1000


def segment(trajectory: Trajectory, robot: Robot, *, tolerance_deg: float = 0.5,
            bus_margin_ms: float = DEFAULT_BUS_MARGIN_MS) -> TickPlan:
    """The fewest ticks (greedy farthest reach) that follow ``trajectory`` within
    ``tolerance_deg`` (plus rounding to whole units) and leave the bus time to stage each next
    tick: ``(10·N + 6)`` bytes at the robot's baud rate plus ``bus_margin_ms``, N counted as
    every servo of the robot so the floor holds whatever the next tick stages.

    ``PlanningError`` if a servo would leave its range (0..1000 units; never clamped) or if the
    bus floor makes the tolerance unreachable.
    """
    if not tolerance_deg > 0:
        raise ValueError(f"tolerance_deg must be > 0, got {tolerance_deg}")
    if bus_margin_ms < 0:
        raise ValueError(f"bus_margin_ms must be >= 0, got {bus_margin_ms}")
    if trajectory.joint_names != robot.joint_names:
        raise ValueError(f"the trajectory's joints {trajectory.joint_names} are not the robot's "
                         f"{robot.joint_names}")
    end_ms = math.ceil(round(trajectory.duration_s * 1000, 6))
    if end_ms == 0:
        return TickPlan((), tolerance_deg, 0.0, 0, 0.0)
    servo = _ServoMap(robot)
    floor_ms = math.ceil(wire_time_ms(staging_bytes(len(robot.joints)), robot.bus.baudrate)
                         + bus_margin_ms)
    search = _Search(trajectory, tolerance_deg, end_ms)
    servo.check_range(search.lattice_deg, search.step_ms)
    bounds, ends_deg, forced = search.ticks(floor_ms)
    if forced:
        _check_forced(robot, search, bounds, ends_deg, forced, floor_ms)

    targets = servo.to_units(ends_deg)
    servo.check_targets(targets, bounds)
    staged = targets[1:] != targets[:-1]
    ticks = tuple(Tick(int(a), int(b - a), tuple(t.tolist()), tuple(s.tolist()))
                  for a, b, t, s in zip(bounds[:-1], bounds[1:], targets[1:], staged))
    deviation = search.max_deviation(bounds, servo.to_deg(targets))
    sent = np.array([staging_bytes(int(s.sum())) for s in staged])
    use = wire_time_ms(sent[1:], robot.bus.baudrate) / np.diff(bounds)[:-1]
    plan = TickPlan(ticks, tolerance_deg, deviation, int(sent.sum()),
                    float(use.max()) if use.size else 0.0)
    log.debug("%d ticks, %d bytes, max deviation %.3f° (lattice %d ms)", len(ticks),
              plan.total_bytes, deviation, search.step_ms)
    return plan


class _ServoMap:
    """Joint degrees <-> servo units for the whole robot at once."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.zero = np.array([j.zero_units for j in robot.joints])
        self.direction = np.array([j.direction for j in robot.joints])

    def to_units(self, angles_deg: np.ndarray) -> np.ndarray:
        return np.rint(self.zero + self.direction * angles_deg * UNITS_PER_DEG).astype(int)

    def to_deg(self, units: np.ndarray) -> np.ndarray:
        return (units - self.zero) * self.direction * DEG_PER_UNIT

    def check_range(self, samples_deg: np.ndarray, step_ms: int) -> None:
        """The smooth trajectory stays where the servos can go."""
        units = self.to_units(samples_deg)
        self._raise_outside(units, np.arange(len(units)) * step_ms)

    def check_targets(self, targets: np.ndarray, bounds: np.ndarray) -> None:
        self._raise_outside(targets, bounds)

    def _raise_outside(self, units: np.ndarray, times_ms: np.ndarray) -> None:
        lo, hi = POSITION_RANGE_UNITS
        outside = (units < lo) | (units > hi)
        problems = []
        for j in np.flatnonzero(outside.any(axis=0)):
            joint = self.robot.joints[j]
            k = int(np.flatnonzero(outside[:, j])[0])
            problems.append(f"{joint.name} (servo {joint.servo_id}) would need position "
                            f"{units[k, j]} at {times_ms[k] / 1000:.3f} s, outside the servo's "
                            f"{lo}..{hi}: check its zero ({joint.zero_units:g}), direction and "
                            f"limits in {self.robot.path}")
        if problems:
            raise PlanningError("; ".join(problems))


class _Search:
    """Greedy farthest reach over a sampled trajectory (see the module docstring)."""

    MAX_STEP_MS = 8
    MARGIN_SHARE = 0.02  # of the tolerance given up to the lattice margin

    def __init__(self, trajectory: Trajectory, tolerance_deg: float, end_ms: int):
        self.trajectory = trajectory
        self.tolerance_deg = tolerance_deg
        self.end_ms = end_ms
        peak_acc = trajectory.peak_acceleration_deg_s2()
        self.step_ms = _lattice_step_ms(tolerance_deg * self.MARGIN_SHARE, float(peak_acc.max()),
                                        self.MAX_STEP_MS)
        self.margin_deg = peak_acc * (self.step_ms / 1000) ** 2 / 8  # per joint
        self.lattice_deg = trajectory.positions(np.arange(0, end_ms + 1, self.step_ms) / 1000)
        # 1/d and tolerance/d for lattice points d = 1..max ms after a tick start
        distances = np.arange(1, min(end_ms, MAX_TICK_MS) + 1)[:, None]
        self.inv_d = 1.0 / distances
        self.tol_d = (tolerance_deg - self.margin_deg)[None, :] / distances

    def ticks(self, floor_ms: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """Tick boundaries (ms, from 0 to the end), the trajectory there, and the ticks the bus
        floor forced past their reach."""
        bounds, ends = [0], [self.lattice_deg[0]]
        forced: list[int] = []
        guess = 16
        while bounds[-1] < self.end_ms:
            start, start_deg = bounds[-1], ends[-1]
            limit = min(self.end_ms - start, MAX_TICK_MS)
            reach, reach_deg = self.reach(start, start_deg, limit, guess)
            guess = max(2 * reach // self.step_ms, 4)
            if reach < min(floor_ms, limit):
                forced.append(len(bounds) - 1)
                reach = min(floor_ms, limit)
                reach_deg = self.trajectory.positions(np.array([start + reach]) / 1000)[0]
            bounds.append(start + reach)
            ends.append(reach_deg)
        return np.array(bounds), np.array(ends), forced

    def reach(self, start: int, start_deg: np.ndarray, limit: int,
              guess: int) -> tuple[int, np.ndarray]:
        """The longest chord from ``start`` (ms, at most ``limit`` ms long) that fits, and the
        trajectory at its end.

        A chord of length L fits iff its slope D_L/L lies, for every sample d before L, between
        (D_d - tol)/d and (D_d + tol)/d: a cone that only narrows. One pass over the lattice
        points finds the farthest one that fits; then the milliseconds up to the next lattice
        point are tried against the cone there.
        """
        step = self.step_ms
        k0 = start // step + 1  # the first lattice point after the start
        last = (start + limit) // step
        best = best_deg = cone = None
        low = high = None
        while k0 <= last:
            k1 = min(k0 + guess, last + 1)
            d0 = k0 * step - start  # distance of lattice point k0 from the start (ms)
            rows = slice(d0 - 1, d0 - 1 + (k1 - k0) * step, step)
            samples = self.lattice_deg[k0:k1]
            slope = (samples - start_deg) * self.inv_d[rows]
            tol = self.tol_d[rows]
            lo = np.maximum.accumulate(slope - tol, axis=0)
            hi = np.minimum.accumulate(slope + tol, axis=0)
            if low is not None:
                np.maximum(lo, low, out=lo)
                np.minimum(hi, high, out=hi)
            fits = np.flatnonzero(((lo <= slope) & (slope <= hi)).all(axis=1))
            if fits.size:
                i = int(fits[-1])
                best, best_deg, cone = k0 + i, samples[i], (lo[i], hi[i])
            low, high = lo[-1], hi[-1]
            if (low > high).any():  # closed: no chord beyond can fit
                break
            k0, guess = k1, 2 * guess
        best_ms = start if best is None else best * step
        return self.refine(start, start_deg, best_ms, best_deg, cone, limit)

    def refine(self, start: int, start_deg: np.ndarray, best_ms: int,
               best_deg: np.ndarray | None, cone: tuple[np.ndarray, np.ndarray] | None,
               limit: int) -> tuple[int, np.ndarray]:
        """The farthest whole-millisecond end short of the next lattice point that still fits
        (any does when no lattice point lies between: the margin covers it)."""
        ends = np.arange(best_ms + 1, min(best_ms + self.step_ms, start + limit + 1))
        if ends.size == 0:
            return best_ms - start, best_deg
        ends_deg = self.trajectory.positions(ends / 1000)
        if cone is None:
            return int(ends[-1]) - start, ends_deg[-1]
        slope = (ends_deg - start_deg) * self.inv_d[ends - start - 1]
        fits = np.flatnonzero(((cone[0] <= slope) & (slope <= cone[1])).all(axis=1))
        if fits.size == 0:
            return best_ms - start, best_deg
        return int(ends[fits[-1]]) - start, ends_deg[fits[-1]]

    def max_deviation(self, bounds: np.ndarray, path_deg: np.ndarray) -> float:
        """An upper bound (exact at the lattice points and tick ends, plus the lattice margin) on
        how far the servos' piecewise-linear path through the rounded targets strays from the
        smooth trajectory."""
        times = np.arange(len(self.lattice_deg)) * self.step_ms
        worst = 0.0
        for j in range(path_deg.shape[1]):
            linear = np.interp(times, bounds, path_deg[:, j])
            off = np.abs(linear - self.lattice_deg[:, j]).max() + self.margin_deg[j]
            worst = max(worst, float(off))
        return worst


def _lattice_step_ms(margin_deg: float, peak_acc_deg_s2: float, max_step_ms: int) -> int:
    """The widest lattice step whose margin A·step²/8 stays within ``margin_deg``."""
    if peak_acc_deg_s2 <= 0:
        return max_step_ms
    step_s = math.sqrt(8 * margin_deg / peak_acc_deg_s2)
    return max(1, min(max_step_ms, int(step_s * 1000)))


def _check_forced(robot: Robot, search: _Search, bounds: np.ndarray, ends_deg: np.ndarray,
                  forced: list[int], floor_ms: int) -> None:
    """Ticks stretched to the bus floor must still meet the tolerance (checked every ms)."""
    worst, worst_joint, worst_ms = 0.0, 0, 0
    for k in forced:
        a, b = int(bounds[k]), int(bounds[k + 1])
        times = np.arange(a, b + 1)
        smooth = search.trajectory.positions(times / 1000)
        chord = ends_deg[k] + np.outer((times - a) / (b - a), ends_deg[k + 1] - ends_deg[k])
        error = np.abs(smooth - chord)
        step, joint = np.unravel_index(np.argmax(error), error.shape)
        if error[step, joint] > worst:
            worst, worst_joint, worst_ms = float(error[step, joint]), int(joint), a + int(step)
    if worst <= search.tolerance_deg:
        return
    name = robot.joints[worst_joint].name
    raise PlanningError(
        f"tolerance {search.tolerance_deg:g}° cannot be met at the bus rate: a tick must last at "
        f"least {floor_ms} ms to stage {len(robot.joints)} servos at {robot.bus.baudrate} baud, "
        f"and then {name} strays {worst:.3f}° at {worst_ms / 1000:.3f} s; use a tolerance of "
        f"at least {math.ceil(worst * 100) / 100:g}° or lower {name}'s acceleration limit")
