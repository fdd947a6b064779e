"""Trajectory -> ticks: the servos' own linear moves, staged on the bus and started together.

A servo can only do "move linearly to P over T ms, from wherever you are now". A tick is one
such move for every servo at once: during tick k the player stages tick k+1 with
MOVE_TIME_WAIT_WRITE (only to the servos whose target changes: the others keep their preset,
which survives START, and are already at it) and starts it with one broadcast MOVE_START.

Ticks are chosen greedily, each as long as it can be (farthest reach): every joint's chord over
the tick must stay within ``tolerance_deg`` of the smooth trajectory, and no tick may be shorter
than the bus needs to stage the next one. Rounding targets to whole servo units adds at most
half a unit (0.12°) on top.

How the chord is checked, cheaply and without gaps: the trajectory is sampled every ``step`` ms
(2, or 1 for very tight tolerances); between two samples a curve whose acceleration stays below
A leaves the straight line through them by at most A·step²/8 (the margin, 0.0015° for 3000°/s²
at 2 ms), so a chord that stays within ``tolerance - margin`` of the samples stays within
``tolerance`` everywhere. Tick boundaries are on that lattice; the last tick may end up to
``step - 1`` ms after the trajectory, which rests there. On trial motions a 2 ms lattice needed
about 1 % more ticks than a 1 ms one, for half the work.

The search runs on one thread. Sharing a long motion's lattice with a second thread (numpy
releases Python's lock) was tried: on an idle 2-core machine it took 1.3-1.4 s of wall time where
one thread takes 1.1 s, for a third more CPU, since each step is too small to pay for the handover.
Half the lattice and lanes in a forked child (its samples written to memory shared with the
parent, its reaches sent back; the same ticks) lost too: with other work on the machine a whole
``choreo plan`` of a 2,000-keyframe motion took 10 % more wall and CPU time (paired runs), the
child's copy-on-write faults and the shared pages costing more than the second core gave.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from choreo.bus.protocol import BYTE_TIME_S, SPECS, Command
from choreo.bus.servo_models import DEG_PER_UNIT, POSITION_RANGE_UNITS
from choreo.core.arguments import Range, check_number
from choreo.errors import PlanningError
from choreo.plan.trajectory import Trajectory
from choreo.robot.types import Robot, Values

log = logging.getLogger(__name__)

# Beyond a few degrees the ticks no longer follow the planned motion: its shape is lost (and an
# unbounded tolerance would overflow the tick search).
TOLERANCE_DEG = Range(above=0, at_most=5.0, unit="°")
DEFAULT_TOLERANCE_DEG = 0.5  # about two servo steps (0.24° each)
_STAGE = SPECS[Command.MOVE_TIME_WAIT_WRITE]
MOVE_BYTES = _STAGE.request_len + 3  # a whole staged-move packet: 10 bytes
START_BYTES = SPECS[Command.MOVE_START].request_len + 3  # broadcast MOVE_START: 6 bytes
MAX_TICK_MS = next(f.hi for f in _STAGE.request if f.name == "time_ms")
DEFAULT_BUS_MARGIN_MS = 1.5  # slack per tick beyond the wire time (host jitter, START gap)
QUANTIZATION_DEG = DEG_PER_UNIT / 2  # rounding a target to whole units
MAX_STEP_MS = 2  # the sample lattice (1 ms when the tolerance is too tight for 2)
MARGIN_SHARE = 0.02  # of the tolerance the lattice margin may take
LANES = 128  # greedy chains searched side by side (see _Search)
LANE_MIN_STEPS = 500  # lattice steps per lane at least: a short motion has fewer lanes
# chords each lane tries per numpy call: 16 with many lanes, up to 128 with few
WINDOW_CHORDS = 2048  # for all lanes together
WINDOW_STEPS = (16, 128)
RUNNING_ROW_BY_ROW = 512  # elements a row at least, for a running maximum row by row
FOLD_ROWS = 16  # rows reduced as one (see _per_column)
DEVIATION_TICKS = 256  # ticks whose deviation is found per numpy call


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


def wire_time_ms(n_bytes: Values) -> Values:
    """Time on the wire of ``n_bytes`` (element-wise on arrays)."""
    return n_bytes * BYTE_TIME_S * 1000


def compile_ticks(
    trajectory: Trajectory,
    robot: Robot,
    *,
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
    bus_margin_ms: float = DEFAULT_BUS_MARGIN_MS,
) -> TickPlan:
    """The fewest ticks (greedy farthest reach) that follow ``trajectory`` within
    ``tolerance_deg`` (plus rounding to whole units) and leave the bus time to stage each next
    tick: ``(10·N + 6)`` bytes at the robot's baud rate plus ``bus_margin_ms``, N counted as
    every servo of the robot so the floor holds whatever the next tick stages.

    ``PlanningError`` if a servo would leave its range (0..1000 units; never clamped) or if the
    bus floor makes the tolerance unreachable.
    """
    _check_arguments(trajectory, robot, tolerance_deg, bus_margin_ms)
    end_ms = math.ceil(round(trajectory.duration_s * 1000, 6))
    if end_ms == 0:
        return TickPlan((), tolerance_deg, 0.0, 0, 0.0)
    servo = _ServoPositions(robot)
    floor_ms = math.ceil(wire_time_ms(staging_bytes(len(robot.joints))) + bus_margin_ms)
    search = _Search(trajectory, tolerance_deg, end_ms)
    servo.check_range(search.samples_deg, search.step_ms)
    bounds, forced = search.ticks(floor_ms)
    if forced:
        _check_forced(robot, search, bounds, forced, floor_ms)
    targets = servo.to_units(search.samples_deg[bounds])
    servo.check_targets(targets, bounds * search.step_ms)
    plan = _tick_plan(search, bounds, targets, robot)
    log.debug(
        "%d ticks, %d bytes, max deviation %.3f° (lattice %d ms)",
        len(plan.ticks),
        plan.total_bytes,
        plan.max_deviation_deg,
        search.step_ms,
    )
    return plan


def _check_arguments(
    trajectory: Trajectory, robot: Robot, tolerance_deg: float, bus_margin_ms: float
) -> None:
    check_number("tolerance_deg", tolerance_deg, TOLERANCE_DEG)
    if bus_margin_ms < 0:
        raise ValueError(f"bus_margin_ms must be >= 0, got {bus_margin_ms}")
    if trajectory.joint_names != robot.joint_names:
        raise ValueError(
            f"the trajectory's joints {trajectory.joint_names} are not the robot's "
            f"{robot.joint_names}"
        )


def _tick_plan(search: _Search, bounds: np.ndarray, targets: np.ndarray, robot: Robot) -> TickPlan:
    """The ticks between the lattice points ``bounds`` (targets in units at each), with what
    they send and how far they stray."""
    bounds_ms = bounds * search.step_ms
    staged = targets[1:] != targets[:-1]
    ticks = tuple(  # map, not a generator: a third faster over thousands of ticks
        map(
            Tick,
            bounds_ms[:-1].tolist(),
            np.diff(bounds_ms).tolist(),
            map(tuple, targets[1:].tolist()),
            map(tuple, staged.tolist()),
        )
    )
    deviation = search.max_deviation(bounds, robot.to_deg(targets))
    n_staged = staged.sum(axis=1)
    sent = np.where(n_staged > 0, n_staged * MOVE_BYTES + START_BYTES, 0)
    use = wire_time_ms(sent[1:]) / np.diff(bounds_ms)[:-1]
    peak_use = float(use.max()) if use.size else 0.0
    return TickPlan(ticks, search.tolerance_deg, deviation, int(sent.sum()), peak_use)


class _ServoPositions:
    """Joint degrees -> whole servo units for the whole robot at once, kept inside the servos'
    range."""

    def __init__(self, robot: Robot):
        self.robot = robot

    def to_units(self, angles_deg: np.ndarray) -> np.ndarray:
        return np.rint(self.robot.to_units(angles_deg)).astype(int)

    def check_range(self, samples_deg: np.ndarray, step_ms: int) -> None:
        """The smooth trajectory stays where the servos can go."""
        low = self.to_units(_per_column(np.minimum, samples_deg))
        high = self.to_units(_per_column(np.maximum, samples_deg))
        lo, hi = POSITION_RANGE_UNITS
        if min(low.min(), high.min()) < lo or max(low.max(), high.max()) > hi:
            self._raise_outside(self.to_units(samples_deg), np.arange(len(samples_deg)) * step_ms)

    def check_targets(self, targets: np.ndarray, bounds_ms: np.ndarray) -> None:
        self._raise_outside(targets, bounds_ms)

    def _raise_outside(self, units: np.ndarray, times_ms: np.ndarray) -> None:
        lo, hi = POSITION_RANGE_UNITS
        outside = (units < lo) | (units > hi)
        problems = []
        for j in np.flatnonzero(outside.any(axis=0)):
            joint = self.robot.joints[j]
            k = int(np.flatnonzero(outside[:, j])[0])
            problems.append(
                f"{joint.name} (servo {joint.servo_id}) would need position "
                f"{units[k, j]} at {times_ms[k] / 1000:.3f} s, outside the servo's "
                f"{lo}..{hi}: check its zero ({joint.zero_units:g}), direction and "
                f"limits in {self.robot.path}"
            )
        if problems:
            raise PlanningError(problems)


class _Search:
    """Greedy farthest reach over the sampled trajectory, in lattice steps (see the module
    docstring).

    The reach from one tick start depends only on that start, so greedy chains begun at points
    spread over the motion (lanes) are searched side by side, one numpy call for every lane's
    window at once (a window alone is too small for numpy: its calls, not its arithmetic, took
    the time). A lane stops where it lands on a start another lane has taken, from which the
    rest is known; greedy chains begun apart were seen to meet within 1-7 ticks. The chain
    from 0 is then read off the reaches found, searching on from any point no lane reached.
    """

    def __init__(self, trajectory: Trajectory, tolerance_deg: float, end_ms: int):
        self.trajectory = trajectory
        self.tolerance_deg = tolerance_deg
        self.n = trajectory.n_joints
        peak_acc = trajectory.peak_acceleration_deg_s2()
        self.step_ms = _lattice_step_ms(tolerance_deg * MARGIN_SHARE, float(peak_acc.max()))
        self.margin_deg = peak_acc * (self.step_ms / 1000) ** 2 / 8  # per joint
        self.end = math.ceil(end_ms / self.step_ms)  # last lattice point: at or after the end
        self.max_steps = MAX_TICK_MS // self.step_ms
        times_s = np.arange(self.end + 1) * self.step_ms / 1000
        self.samples_deg = np.ascontiguousarray(trajectory.positions(times_s))  # (time, joint)
        # 1/d for chords d = 1..max steps long
        self.inv_d = 1.0 / np.arange(1, min(self.end, self.max_steps) + 1)
        self.tol_deg = tolerance_deg - self.margin_deg  # what the samples may stray, per joint
        self.next_point: dict[int, int] = {}  # each start's reach, as a lattice point
        self.forced_from: set[int] = set()  # starts whose tick the bus floor lengthened
        self.taken: set[int] = set()  # starts a lane has searched or is searching from

    def ticks(self, floor_ms: int) -> tuple[np.ndarray, list[int]]:
        """Tick boundaries (lattice indices, from 0 to the end) and the ticks the bus floor
        forced past their reach: each next boundary is the farthest reach from the last, or
        the bus floor past it."""
        floor = math.ceil(floor_ms / self.step_ms)
        n_lanes = max(1, min(LANES, self.end // LANE_MIN_STEPS))
        starts = [self.end * k // n_lanes for k in range(n_lanes)]
        # a lane gives up a whole lane's length past the next one's start, if not met by then
        caps = starts[2:] + [self.end] * min(2, n_lanes)
        self._follow(starts, caps, floor)
        points, forced = [0], []
        while points[-1] < self.end:
            start = points[-1]
            if start not in self.next_point:
                self._follow([start], [self.end], floor)
            if start in self.forced_from:
                forced.append(len(points) - 1)
            points.append(self.next_point[start])
        return np.array(points), forced

    def _follow(self, starts: list[int], caps: list[int], floor: int) -> None:
        """Greedy chains from ``starts``, side by side, each until it lands on a start already
        taken, at the end, or at or past its cap."""
        self.taken.update(starts)
        lanes = _Lanes.fresh(np.array(starts), np.array(caps), self.n)
        while lanes.start.size:
            limit = np.minimum(self.end - lanes.start, self.max_steps)
            done = np.flatnonzero(self._window(lanes, limit))
            if not done.size:
                continue
            stopped = []
            for lane, start, reach, lane_limit, cap in zip(
                done.tolist(),
                lanes.start[done].tolist(),
                lanes.best[done].tolist(),
                limit[done].tolist(),
                lanes.cap[done].tolist(),
            ):
                if reach < min(floor, lane_limit):
                    self.forced_from.add(start)
                    reach = min(floor, lane_limit)
                point = start + reach
                self.next_point[start] = point
                if point >= self.end or point >= cap or point in self.taken:
                    stopped.append(lane)
                else:
                    self.taken.add(point)
                lanes.start[lane] = point
            lanes.restart(done)
            if stopped:
                lanes.drop(stopped)

    def _window(self, lanes: _Lanes, limit: np.ndarray) -> np.ndarray:
        """Every lane's next window of chords (``lanes.window`` lengths from ``lanes.first``):
        narrows each lane's cone, keeps its longest chord that fits; True for the lanes whose
        search is over (cone closed, or their limit reached).

        A chord of length L fits iff its slope D_L/L lies, for every sample d before L, between
        (D_d - tol)/d and (D_d + tol)/d: a cone that only narrows, so one pass over the chords
        in order finds every chord that fits, and once a joint's cone is closed none further
        does.
        """
        steps = lanes.first + np.arange(lanes.window)[:, None]  # (window, lanes)
        inside = steps <= limit
        # past a lane's limit its last chord again: no new bound, and masked out of the fits
        np.minimum(steps, limit, out=steps)
        samples = self.samples_deg
        # each lane's rows in turn (as they lie in memory), then as (window, joints, lanes);
        # take, not fancy indexing: the same rows for a third of the work
        chords = samples.take((lanes.start + steps).T, axis=0)
        chords -= samples[lanes.start][:, None]
        slope = np.ascontiguousarray(chords.transpose(1, 2, 0))
        slope *= self.inv_d[steps - 1][:, None]
        # as tol_d was: tol / d, with d made a float once per chord, not once per joint (numpy
        # would cast it element by element through its buffers: a tenth of the search's work)
        tol = np.divide(self.tol_deg[:, None], steps.astype(float)[:, None])
        low = slope - tol
        high = np.add(slope, tol, out=tol)
        # the cone so far into the first chord's bounds, then along the chords (fmax, not
        # maximum: the samples are finite, so they agree, and fmax skips the NaN handling)
        np.fmax(low[0], lanes.low, out=low[0])
        np.fmin(high[0], lanes.high, out=high[0])
        _running(np.fmax, low)
        _running(np.fmin, high)
        fits = np.logical_and.reduce(np.logical_and(low <= slope, slope <= high), axis=1)
        fits &= inside
        last = lanes.window - 1 - fits[::-1].argmax(axis=0)
        lanes.best = np.where(fits.any(axis=0), lanes.first + last, lanes.best)
        lanes.low, lanes.high = low[-1], high[-1]
        lanes.first += lanes.window
        return (lanes.low > lanes.high).any(axis=0) | (lanes.first > limit)

    def max_deviation(self, bounds: np.ndarray, path_deg: np.ndarray) -> float:
        """An upper bound (exact at the samples, plus the lattice margin) on how far the servos'
        piecewise-linear path through the rounded targets strays from the smooth trajectory."""
        largest_off = np.abs(path_deg[-1] - self.samples_deg[-1])
        for first in range(0, len(bounds) - 1, DEVIATION_TICKS):  # a few at a time: in cache
            ticks = slice(first, first + DEVIATION_TICKS + 1)
            off = self._offsets(bounds[ticks], path_deg[ticks])
            np.maximum(largest_off, _per_column(np.maximum, off), out=largest_off)
        return float((largest_off + self.margin_deg).max())

    def _offsets(self, bounds: np.ndarray, path_deg: np.ndarray) -> np.ndarray:
        """|path - samples| at every lattice point from the first bound to before the last, the
        path straight between the targets ``path_deg`` at ``bounds``: as np.interp finds it (the
        same arithmetic, so the same figure), for every joint at once."""
        lengths = np.diff(bounds)
        slopes = np.diff(path_deg, axis=0) / lengths.astype(float)[:, None]
        into = np.arange(bounds[0], bounds[-1]) - np.repeat(bounds[:-1], lengths)  # steps
        off = np.repeat(slopes, lengths, axis=0)
        off *= into.astype(float)[:, None]
        off += np.repeat(path_deg[:-1], lengths, axis=0)
        off -= self.samples_deg[bounds[0] : bounds[-1]]
        return np.abs(off, out=off)


@dataclass
class _Lanes:
    """Greedy chains searched side by side (see ``_Search``), one entry per lane: the start of
    the tick it seeks, the chord length its next window begins with, the longest chord found to
    fit so far, its cone so far (each joint's lowest and highest slope) and the point at or
    past which it gives up."""

    start: np.ndarray
    cap: np.ndarray
    first: np.ndarray
    best: np.ndarray
    low: np.ndarray  # (joints, lanes)
    high: np.ndarray
    window: int

    @staticmethod
    def fresh(starts: np.ndarray, caps: np.ndarray, n_joints: int) -> _Lanes:
        k = len(starts)
        return _Lanes(
            starts,
            caps,
            np.ones(k, dtype=int),
            np.zeros(k, dtype=int),
            np.full((n_joints, k), -np.inf),
            np.full((n_joints, k), np.inf),
            min(max(WINDOW_CHORDS // k, WINDOW_STEPS[0]), WINDOW_STEPS[1]),
        )

    def restart(self, lanes: np.ndarray) -> None:
        """``lanes`` begin the search of a new tick (from their ``start``)."""
        self.first[lanes] = 1
        self.best[lanes] = 0
        self.low[:, lanes] = -np.inf
        self.high[:, lanes] = np.inf

    def drop(self, lanes: list[int]) -> None:
        keep = np.ones(len(self.start), dtype=bool)
        keep[lanes] = False
        self.start, self.cap = self.start[keep], self.cap[keep]
        self.first, self.best = self.first[keep], self.best[keep]
        self.low, self.high = self.low[:, keep], self.high[:, keep]


def _per_column(op: np.ufunc, rows: np.ndarray) -> np.ndarray:
    """``op.reduce(rows, axis=0)``, the rows first folded 16 to one: numpy reduces a row at a
    time, and a row of a joint or two dozen is too short to pay for its call."""
    n_rows, n_columns = rows.shape
    whole = n_rows // FOLD_ROWS * FOLD_ROWS
    if not whole:
        return op.reduce(rows, axis=0)
    folded = op.reduce(rows[:whole].reshape(-1, FOLD_ROWS * n_columns), axis=0)
    return op.reduce(np.concatenate([folded.reshape(FOLD_ROWS, n_columns), rows[whole:]]), axis=0)


def _running(op: np.ufunc, rows: np.ndarray) -> None:
    """``op.accumulate`` along the first axis, in place: numpy's own is many times slower
    there. Wide rows one after the other; a few narrow ones (a lone lane) by doubling spans
    (log2 calls of numpy, each on them all)."""
    if rows[0].size >= RUNNING_ROW_BY_ROW:
        previous, *rest = rows  # each row's view made once (indexing made two a row)
        for row in rest:
            op(previous, row, out=row)
            previous = row
        return
    span = 1
    while span < len(rows):
        op(rows[span:], rows[:-span].copy(), out=rows[span:])  # the rows as they were
        span *= 2


def _lattice_step_ms(margin_deg: float, peak_acc_deg_s2: float) -> int:
    """The widest lattice step whose margin A·step²/8 stays within ``margin_deg``."""
    if peak_acc_deg_s2 <= 0:
        return MAX_STEP_MS
    step_s = math.sqrt(8 * margin_deg / peak_acc_deg_s2)
    return max(1, min(MAX_STEP_MS, int(step_s * 1000)))


def _check_forced(
    robot: Robot, search: _Search, bounds: np.ndarray, forced: list[int], floor_ms: int
) -> None:
    """Ticks stretched to the bus floor must still meet the tolerance (checked every ms)."""
    worst, worst_joint, worst_ms = 0.0, 0, 0
    for k in forced:
        a, b = int(bounds[k]) * search.step_ms, int(bounds[k + 1]) * search.step_ms
        times = np.arange(a, b + 1)
        smooth = search.trajectory.positions(times / 1000)
        chord = smooth[0] + np.outer((times - a) / (b - a), smooth[-1] - smooth[0])
        error = np.abs(smooth - chord)
        step, joint = np.unravel_index(np.argmax(error), error.shape)
        if error[step, joint] > worst:
            worst, worst_joint, worst_ms = float(error[step, joint]), int(joint), a + int(step)
    if worst <= search.tolerance_deg:
        return
    name = robot.joints[worst_joint].name
    raise PlanningError(
        f"tolerance {search.tolerance_deg:g}° cannot be met at the bus rate: a tick must last at "
        f"least {floor_ms} ms to stage {len(robot.joints)} servos at 115200 baud, "
        f"and then {name} strays {worst:.3f}° at {worst_ms / 1000:.3f} s; use a tolerance of "
        f"at least {math.ceil(worst * 100) / 100:g}° or lower {name}'s acceleration limit"
    )
