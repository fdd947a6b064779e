"""A planned motion as piecewise constant-jerk polynomials: ``Trajectory`` (sampled with numpy,
no ruckig needed to read it), the ``PlanResult`` that carries it with the keyframes stretched to
reach it, and how the planner's ruckig profiles are assembled into one (``assemble``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from itertools import chain
from typing import NamedTuple

import numpy as np

from choreo.core.yaml_source import SourceLocation

PHASES = 7  # constant-jerk phases of one ruckig profile
_DENSE_QUERY = 256  # longer sorted queries are evaluated joint by joint (cheaper there)
_DENSE_CHUNK = 16384  # times evaluated at once in a long sorted query


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Every joint's motion as piecewise constant-jerk polynomials (degrees, seconds), starting
    at 0; after ``duration_s`` the robot rests at the last pose."""

    joint_names: tuple[str, ...]
    duration_s: float
    keyframe_times_s: tuple[float, ...]  # arrival at each played keyframe
    # Phase k of joint j starts at knots_s[j, k] with position, velocity, acceleration and jerk
    # poly[:, j, k]. Each row of knots_s is sorted, starts at 0 and ends with a rest phase.
    knots_s: np.ndarray = field(repr=False)
    poly: np.ndarray = field(repr=False)
    # Derived from knots_s and poly in __post_init__, for evaluating many times at once.
    _taylor: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.knots_s.flags.writeable = False
        self.poly.flags.writeable = False
        p, v, a, j = self.poly
        # (4, n, phases): p + v·t + a/2·t² + j/6·t³
        object.__setattr__(self, "_taylor", np.stack([p, v, a / 2, j / 6]))

    @cached_property
    def _few_times_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For few times: every joint's knots in one sorted array (joint j shifted by j * span,
        the shifts returned too), the Taylor coefficients of every phase in one row of a table.
        Made on first use: long queries do without them, and so does ``choreo plan`` (some
        0.01 s for a 2,000-keyframe motion)."""
        offsets = (self.duration_s + 1.0) * np.arange(self.n_joints)[:, None]
        flat_knots = (self.knots_s + offsets).ravel()
        return offsets, flat_knots, self._taylor.reshape(4, -1).T.copy()

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def sample(self, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration) at ``times_s``, each ``(len(times_s), n_joints)``."""
        pos, vel, acc = self._evaluate(self._checked_times(times_s), rates=True)
        return pos, vel, acc

    def positions(self, times_s: np.ndarray) -> np.ndarray:
        """Positions only (cheaper than ``sample``), ``(len(times_s), n_joints)`` degrees."""
        return self._evaluate(self._checked_times(times_s), rates=False)[0]

    def at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, velocity, acceleration) at one time, each ``(n_joints,)``."""
        pos, vel, acc = self.sample(np.array([t_s], dtype=float))
        return pos[0], vel[0], acc[0]

    def peak_velocity_deg_s(self) -> np.ndarray:
        """Largest |velocity| of each joint over the whole trajectory (exact), ``(n_joints,)``."""
        v0, a0, jerk = self.poly[1], self.poly[2], self.poly[3]
        tau = self._phase_lengths_s()
        v_end = v0 + tau * (a0 + tau * jerk / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            turn = np.where(jerk != 0, -a0 / jerk, -1.0)  # where the acceleration crosses zero
        inside = (turn > 0) & (turn < tau)
        v_turn = np.where(inside, v0 + turn * (a0 + turn * jerk / 2), 0.0)
        return np.max(np.abs(np.concatenate([v0, v_end, v_turn], axis=1)), axis=1)

    def peak_acceleration_deg_s2(self) -> np.ndarray:
        """Largest |acceleration| of each joint (exact: it is linear within a phase)."""
        a0, jerk = self.poly[2], self.poly[3]
        a_end = a0 + self._phase_lengths_s() * jerk
        return np.maximum(np.abs(a0), np.abs(a_end)).max(axis=1)

    def _phase_lengths_s(self) -> np.ndarray:
        return np.diff(self.knots_s, axis=1, append=self.knots_s[:, -1:])

    @staticmethod
    def _checked_times(times_s: np.ndarray) -> np.ndarray:
        times_s = np.asarray(times_s, dtype=float)
        if times_s.ndim != 1:
            raise ValueError(f"times_s must be one-dimensional, got shape {times_s.shape}")
        if times_s.size and not times_s.min() >= 0:
            raise ValueError(
                f"times_s must be >= 0 (the trajectory starts at 0), got {times_s.min()}"
            )
        return times_s

    def _evaluate(self, times_s: np.ndarray, rates: bool) -> list[np.ndarray]:
        """Position (and velocity, acceleration if ``rates``) at every time, ``(len, n)`` each."""
        # After the end the last (rest) phase holds: locating by the clamped time finds it.
        located = np.minimum(times_s, self.duration_s)
        if len(located) <= _DENSE_QUERY or np.any(located[1:] < located[:-1]):
            offsets, flat_knots, taylor_rows = self._few_times_tables
            index = np.searchsorted(flat_knots, located + offsets, side="right")
            index -= 1
            dt = times_s - self.knots_s.ravel()[index]
            c = taylor_rows[index]
            values = _taylor_values(c[..., 0], c[..., 1], c[..., 2], c[..., 3], dt, rates)
            return [array.T for array in values]
        # Long sorted queries: a chunk of times at a time (so that the arrays stay in cache)
        out = [np.empty((len(located), self.n_joints)) for _ in range(3 if rates else 1)]
        for first in range(0, len(located), _DENSE_CHUNK):
            chunk = slice(first, first + _DENSE_CHUNK)
            self._evaluate_sorted(located[chunk], times_s[chunk], [a[chunk] for a in out])
        return out

    def _evaluate_sorted(
        self, located: np.ndarray, times_s: np.ndarray, out: list[np.ndarray]
    ) -> None:
        """Into ``out`` (``(len, n)`` each): joint by joint, the times falling in each phase
        counted, from the phase holding the first to the one holding the last."""
        rows = [np.empty((self.n_joints, len(located))) for _ in out]
        # the ndarray's own searchsorted, and counts by subtraction rather than np.diff: numpy's
        # functions add Python calls, and these run for every joint of every chunk
        for j, knots in enumerate(self.knots_s):
            first = int(knots.searchsorted(located[0], side="right")) - 1
            last = int(knots.searchsorted(located[-1], side="right"))
            knots = knots[first:last]
            begins = located.searchsorted(knots, side="left")
            counts = np.empty_like(begins)
            np.subtract(begins[1:], begins[:-1], out=counts[:-1])
            counts[-1] = len(located) - begins[-1]
            dt = times_s - np.repeat(knots, counts)
            p, v, a_half, j_sixth = (
                np.repeat(column[j, first:last], counts) for column in self._taylor
            )
            values = _taylor_values(p, v, a_half, j_sixth, dt, len(out) > 1)
            for array, value in zip(rows, values):
                array[j] = value
        for array, row in zip(out, rows):  # joint-major in cache, then into place at once
            array[...] = row.T


def _taylor_values(
    p: np.ndarray,
    v: np.ndarray,
    a_half: np.ndarray,
    j_sixth: np.ndarray,
    dt: np.ndarray,
    rates: bool,
) -> list[np.ndarray]:
    """Position (and velocity, acceleration if ``rates``)."""
    pos = j_sixth * dt
    pos += a_half
    pos *= dt
    pos += v
    pos *= dt
    pos += p
    if not rates:
        return [pos]
    vel = 3 * j_sixth * dt
    vel += 2 * a_half
    vel *= dt
    vel += v
    acc = 6 * j_sixth * dt
    acc += 2 * a_half
    return [pos, vel, acc]


class Stretch(NamedTuple):
    """A keyframe that could not be reached at its time and was moved later (``stretch=True``);
    a ``(where, shift_s)`` pair."""

    where: SourceLocation
    shift_s: float  # played seconds (after speed scaling) this keyframe and the later ones moved

    def describe(self) -> str:
        """The warning play, its dry run and validate give for it."""
        return f"{self.where}: stretched: reached {self.shift_s:.3f} s later than written"


@dataclass(frozen=True)
class PlanResult:
    trajectory: Trajectory
    stretches: tuple[Stretch, ...] = ()


@dataclass(frozen=True)
class Profile:
    """One ruckig result between two keyframes: every joint's seven phase durations and jerks,
    flat lists in joint order (as ruckig gives them; turned into arrays for all segments at
    once)."""

    p0: list[float]  # start position and velocity (acceleration is zero at keyframes)
    v0: list[float]
    duration_s: float
    phase_s: list[float]  # [joint * 7 + phase]
    jerk: list[float]
    overshoot: list[int]  # joints that leave the range between their two keyframes


def assemble(
    joint_names: tuple[str, ...],
    positions: np.ndarray,
    segments: list[Profile],
    arrive: np.ndarray,
    holds_s: np.ndarray,
) -> Trajectory:
    """Phases in time order: a wait before the first keyframe, then per keyframe its hold (one
    constant phase) and the 7 phases to the next keyframe, then a rest at the last pose."""
    m, n = positions.shape
    seg_knots, seg_poly = _integrate(arrive[:-1] + holds_s[:-1], positions[:-1], segments)
    has_hold = holds_s > 0
    rows_per_keyframe = has_hold.astype(int) + np.append(np.full(m - 1, PHASES), 0)
    first_row = 1 + np.concatenate(([0], np.cumsum(rows_per_keyframe)[:-1]))  # row 0: the wait
    total = 1 + rows_per_keyframe.sum() + 1
    knots = np.empty((total, n))
    poly = np.zeros((4, total, n))
    constant_rows = np.concatenate(([0], first_row[has_hold], [total - 1]))
    constant_pose = np.concatenate((positions[:1], positions[has_hold], positions[-1:]))
    constant_start = np.concatenate(([0.0], arrive[has_hold], [arrive[-1] + holds_s[-1]]))
    knots[constant_rows] = constant_start[:, None]
    poly[0, constant_rows] = constant_pose
    seg_rows = np.arange(PHASES)[:, None] + (first_row[:-1] + has_hold[:-1])  # (7, m-1)
    knots[seg_rows] = seg_knots
    poly[:, seg_rows] = seg_poly
    return Trajectory(
        joint_names,
        float(arrive[-1] + holds_s[-1]),
        tuple(float(t) for t in arrive),
        np.ascontiguousarray(knots.T),
        np.ascontiguousarray(poly.transpose(0, 2, 1)),
    )


def _integrate(
    leave_s: np.ndarray, start_deg: np.ndarray, segments: list[Profile]
) -> tuple[np.ndarray, np.ndarray]:
    """Knots (7, S, n) and (p, v, a, j) at each phase start (4, 7, S, n) of all segments, each
    leaving ``start_deg`` (S, n) at ``leave_s``. Phase by phase, over contiguous (S, n) arrays
    (twice as fast as over a (S, n, 7) array's strided columns)."""
    n = start_deg.shape[1]
    if not segments:
        return np.empty((PHASES, 0, n)), np.empty((4, PHASES, 0, n))
    phase_s = _phase_major([s.phase_s for s in segments], n)
    jerk = _phase_major([s.jerk for s in segments], n)
    p = start_deg
    v = np.array([s.v0 for s in segments])  # (S, n)
    a = np.zeros_like(p)
    t = np.repeat(leave_s[:, None], n, axis=1)
    knots = np.empty((PHASES, len(segments), n))
    poly = np.empty((4,) + knots.shape)
    for k in range(PHASES):
        tau, j = phase_s[k], jerk[k]
        knots[k] = t
        poly[0, k], poly[1, k], poly[2, k], poly[3, k] = p, v, a, j
        p = p + tau * (v + tau * (a / 2 + tau * j / 6))
        v = v + tau * (a + tau * j / 2)
        a = a + tau * j
        t = t + tau
    return knots, poly


def _phase_major(per_segment: list[list[float]], n: int) -> np.ndarray:
    """Lists of ``[joint * 7 + phase]`` values, one per segment, as one (7, S, n) array."""
    size = len(per_segment) * n * PHASES
    flat = np.fromiter(chain.from_iterable(per_segment), float, size)
    return np.ascontiguousarray(flat.reshape(len(per_segment), n, PHASES).transpose(2, 0, 1))
