"""Keyframes -> one smooth, jerk-limited, time-synchronized trajectory.

Each interval between two played keyframes is one ruckig trajectory with
``Synchronization.Time``, so every joint leaves and arrives together. A keyframe is passed with
a velocity from a shape-preserving rule (PCHIP, Fritsch–Butland: zero where a joint reverses,
at stop/hold keyframes and at both ends), and a joint never overshoots a keyframe: between two
keyframes it stays between their values. That keeps it inside its position limits, which ruckig
itself ignores; where a segment would overshoot, the pass-through velocities that cause it are
lowered and the affected segments planned again.

Each segment is solved by ``choreo.plan.segment`` (the one module that imports ruckig).

Times: the keyframe timing rules (``t``, ``after``, ``hold``, ``repeat``, speed) are
``choreo.motion.timing``'s; the motion start is the first keyframe's pose, where the approach leaves
the robot.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from choreo.core.arguments import check_flag, check_number, shown
from choreo.errors import OptionError, PlanningError
from choreo.motion.motion_file import Keyframe, Motion, motion_of, too_many_played
from choreo.motion.music_block import repetition_clock
from choreo.motion.timing import (
    MAX_TIME_S,
    SPEED,
    PlayedKeyframe,
    Timing,
    estimated_arrivals_s,
    played_keyframes,
    wanted_arrival_s,
)
from choreo.plan.segment import (
    DURATION_EPS_S,
    Limits,
    NoTrajectory,
    SegmentSolver,
    segment_ranges,
)
from choreo.plan.trajectory import PlanResult, Profile, Stretch, Trajectory, assemble
from choreo.robot.types import Robot

log = logging.getLogger(__name__)

# Longest time between leaving one keyframe and reaching the next. Ruckig 0.19.4 fails beyond
# its numerical limits (RuckigError, or a result code its Python enum doesn't know) from a few
# hundred seconds up when the joints pass through with some velocity; 300 s never failed in
# randomized trials. Longer pauses are a `hold`, which ruckig never sees.
MAX_SEGMENT_S = 300.0
APPROACH_LIMIT_SCALE = 0.3  # approach and exit moves run at this share of every joint limit
VELOCITY_DAMPING = (1.0, 0.5, 0.25, 0.0)  # pass-through velocity factors tried in turn


# --- pass-through velocities -------------------------------------------------------------------
def _pchip_velocities(
    positions: np.ndarray,
    arrive_s: np.ndarray,
    leave_s: np.ndarray,
    rests: np.ndarray,
    vel_cap: np.ndarray,
) -> np.ndarray:
    """Fritsch–Butland (PCHIP) slopes at each keyframe, ``(m, n)`` deg/s: monotone between
    keyframes, zero where a joint reverses and where the motion rests; capped per keyframe."""
    m = len(positions)
    velocities = np.zeros_like(positions)
    if m < 3:
        return velocities
    h = np.maximum(arrive_s[1:] - leave_s[:-1], DURATION_EPS_S)[:, None]  # (m-1, 1)
    d = np.diff(positions, axis=0) / h  # secant slopes
    h0, h1, d0, d1 = h[:-1], h[1:], d[:-1], d[1:]
    w0, w1 = 2 * h1 + h0, h1 + 2 * h0
    same_sign = d0 * d1 > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = np.where(same_sign, (w0 + w1) / (w0 / d0 + w1 / d1), 0.0)
    velocities[1:-1] = np.clip(inner, -vel_cap[1:-1], vel_cap[1:-1])
    velocities[rests] = 0.0
    return velocities


# --- the plan ----------------------------------------------------------------------------------
class _Planner:
    """Plans the segments in time order; backs up one segment when a pass-through velocity it
    already used has to be lowered."""

    def __init__(self, robot: Robot, played: list[PlayedKeyframe[Keyframe]], stretch: bool):
        self.robot = robot
        self.played = played
        self.stretch = stretch
        self.solver = SegmentSolver(len(robot.joints))
        self.positions = np.array([p.keyframe.targets_deg for p in played], dtype=float)
        self.pose_lists = self.positions.tolist()
        self.low, self.high = segment_ranges(self.positions)
        self.holds_s = np.array([p.hold_s for p in played])
        self.scales = np.array([p.keyframe.velocity_scale for p in played])
        self.vel_limits = np.array([j.limits.vel_deg_s for j in robot.joints])
        self._limits_by_scale: dict[float, Limits] = {}

    def segment_limits(self, arrival_index: int) -> Limits:
        """A segment's limits: the velocity scaled by the keyframe it arrives at."""
        scale = float(self.scales[arrival_index])
        if scale not in self._limits_by_scale:
            self._limits_by_scale[scale] = Limits.of(self.robot, velocity_scale=scale)
        return self._limits_by_scale[scale]

    def rest_to_rest_s(self, i: int) -> float:
        zero = [0.0] * len(self.robot.joints)
        try:
            return self.solver.duration_s(
                self.pose_lists[i],
                zero,
                self.pose_lists[i + 1],
                zero,
                self.segment_limits(i + 1),
                None,
            )
        except NoTrajectory as error:
            raise self.no_trajectory(i, error) from None

    def no_trajectory(self, i: int, error: NoTrajectory) -> PlanningError:
        """The move from keyframe i to i + 1 could not be planned, said at keyframe i + 1."""
        kf = self.played[i + 1].keyframe
        return PlanningError(
            f"{kf.where}: the move into keyframe{kf.where.through} could not be planned: "
            + error.message(
                self.robot,
                self.pose_lists[i],
                self.pose_lists[i + 1],
                " and the keyframe's velocity",
            )
        )

    def estimated_times(self) -> tuple[np.ndarray, np.ndarray]:
        """Arrival and leave times as if every timing were met and ASAP keyframes were reached
        from rest: good enough to choose pass-through velocities."""
        arrive = estimated_arrivals_s(self.played, lambda i: self.rest_to_rest_s(i - 1))
        return arrive, arrive + self.holds_s

    def velocity_caps(self) -> np.ndarray:
        """Pass-through speed allowed at each keyframe: both adjacent segments' limits."""
        scale_out = np.append(self.scales[1:], 1.0)
        return np.minimum(self.scales, scale_out)[:, None] * self.vel_limits[None, :]

    def plan(self) -> tuple[list[Profile], np.ndarray, list[Stretch]]:
        m, n = self.positions.shape
        arrive_est, leave_est = self.estimated_times()
        rests = np.array([p.rests for p in self.played])
        velocities = _pchip_velocities(
            self.positions, arrive_est, leave_est, rests, self.velocity_caps()
        )
        damping = np.zeros((m, n), dtype=int)
        arrive = np.zeros(m)
        arrive[0] = wanted_arrival_s(self.played, 0, arrive) or 0.0
        shift = np.zeros(m)  # how much later than asked each keyframe was reached (stretch)
        segments: dict[int, Profile] = {}  # by index: damping may plan one again
        too_early: dict[int, str] = {}  # without stretch: planned on as if stretched, to say all
        i = 0
        while i < m - 1:
            leave = arrive[i] + self.holds_s[i]
            wanted = wanted_arrival_s(self.played, i + 1, arrive, shift)
            requested = None if wanted is None else wanted - leave
            if requested is not None and requested > MAX_SEGMENT_S:
                raise PlanningError(self.too_long_message(i + 1, requested))
            try:
                seg = self.solver.solve(
                    self.pose_lists[i],
                    velocities[i].tolist(),
                    self.pose_lists[i + 1],
                    velocities[i + 1].tolist(),
                    self.segment_limits(i + 1),
                    None if requested is None else max(requested, 0.0),
                    self.low[i],
                    self.high[i],
                )
            except NoTrajectory as error:
                raise self.no_trajectory(i, error) from None
            if seg.overshoot:
                i = self.damp(i, seg.overshoot, velocities, damping)
                continue
            if seg.duration_s > MAX_SEGMENT_S + DURATION_EPS_S:
                raise PlanningError(self.too_slow_message(i + 1, seg.duration_s))
            shift[i + 1] = 0.0
            too_early.pop(i + 1, None)
            if requested is not None and seg.duration_s > requested + DURATION_EPS_S:
                if not self.stretch:
                    earliest = leave + seg.duration_s
                    asked = requested + leave - self.earlier_shift_s(i + 1, shift)  # = wanted
                    too_early[i + 1] = self.too_early_message(i + 1, asked, earliest)
                shift[i + 1] = seg.duration_s - requested
            segments[i] = seg
            arrive[i + 1] = leave + seg.duration_s
            i += 1
        if too_early:
            raise _TooEarly(too_early)
        stretches = [
            Stretch(self.played[k].keyframe.where, float(shift[k])) for k in np.flatnonzero(shift)
        ]
        return [segments[k] for k in range(m - 1)], arrive, stretches

    def earlier_shift_s(self, i: int, shift: np.ndarray) -> float:
        """How much of keyframe i's wanted time comes from stretching keyframes before it."""
        p = self.played[i]
        return float(shift[(p.anchor or 0) + 1 : i].sum()) if p.timing is Timing.AT else 0.0

    def damp(self, i: int, joints: list[int], velocities: np.ndarray, damping: np.ndarray) -> int:
        """Lower the pass-through velocities that make segment i overshoot; return the segment
        to plan next (i again, or i - 1 when its start velocity had to change)."""
        last = len(VELOCITY_DAMPING) - 1
        for k, back in ((i + 1, 0), (i, 1)):
            movable = [j for j in joints if velocities[k, j] != 0 and damping[k, j] < last]
            if movable:
                factor_before = np.take(VELOCITY_DAMPING, damping[k, movable])
                damping[k, movable] += 1
                velocities[k, movable] *= (
                    np.take(VELOCITY_DAMPING, damping[k, movable]) / factor_before
                )
                return i - back
        raise PlanningError(
            f"{self.played[i + 1].keyframe.where}: internal error: the segment "
            f"overshoots even from rest to rest"
        )

    def too_long_message(self, i: int, requested_s: float) -> str:
        p = self.played[i]
        speed = f" (at speed {p.speed:g})" if p.speed != 1 else ""
        return (
            f"{p.keyframe.where}: keyframe{p.keyframe.where.through} reached {requested_s:.6g} s "
            "after leaving the one "
            f"before{speed}; at most {MAX_SEGMENT_S:g} s can be planned between two keyframes: "
            f"hold the one before instead (a hold may last up to {MAX_TIME_S:g} s), or add "
            "keyframes in between"
        )

    def too_slow_message(self, i: int, duration_s: float) -> str:
        """Keyframe i is asked for no later than the limits allow, but that is too late."""
        kf = self.played[i].keyframe
        joint = self.robot.joints[self.solver.limiting_joint()].name
        scale = kf.velocity_scale
        fix = "raise its velocity, or add keyframes in between"
        if scale == 1:
            fix = f"add keyframes in between, or raise {joint}'s velocity in {self.robot.path}"
        return (
            f"{kf.where}: keyframe{kf.where.through} takes {duration_s:.6g} s to reach from the "
            f"one before: the velocity limit of {joint}"
            + (f" x velocity {scale:g}" if scale != 1 else "")
            + f" allows no faster; at most {MAX_SEGMENT_S:g} s can be planned between two "
            f"keyframes: {fix}"
        )

    def too_early_message(self, i: int, wanted: float, earliest: float) -> str:
        p = self.played[i]
        kf = p.keyframe
        joint = self.robot.joints[self.solver.limiting_joint()].name
        late_by = (earliest - wanted) * p.speed  # in the file's seconds
        fix = (
            f"t >= {kf.t_s + late_by:.3f}"
            if p.timing is Timing.AT and kf.t_s is not None
            else f"after >= {(kf.after_s or 0.0) + late_by:.3f}"
        )
        if kf.beat is not None and p.timing is Timing.AT and kf.t_s is not None:
            fix = kf.beat.earliest_fix(kf.t_s + late_by)  # the earliest beat that works
        speed = f" (at speed {p.speed:g})" if p.speed != 1 else ""
        return (
            f"{kf.where}: keyframe{kf.where.through} cannot be reached at {wanted:.3f} s{speed}: "
            f"the velocity, acceleration and jerk limits of {joint} allow {earliest:.3f} s at the "
            f"earliest; use {fix}, a lower speed, or stretch"
        )


class _TooEarly(PlanningError):
    """Keyframes the limits cannot reach in time: played index -> its message."""

    def __init__(self, messages: dict[int, str]):
        super().__init__("\n".join(messages[k] for k in sorted(messages)))
        self.messages = messages


def _gait_blocks(keyframes: Sequence[Keyframe]) -> list[range]:
    """The keyframe indices of each ``gait:`` block."""
    return [
        range(i + 1 - k.gait_end.keyframes, i + 1)
        for i, k in enumerate(keyframes)
        if k.gait_end is not None
    ]


def _too_early_text(motion: Motion, speed: float, messages: dict[int, str]) -> list[str]:
    """The planner's messages, those of a ``gait:`` block's keyframes (``after >=`` advice a
    gait cannot take) replaced by one line at its ``gait:`` line naming the shortest period
    that the limits allow."""
    n = len(motion.keyframes)
    blocks = [b for b in _gait_blocks(motion.keyframes) if any(i % n in b for i in messages)]
    lines = [m for i, m in sorted(messages.items()) if not any(i % n in b for b in blocks)]
    for block in blocks:
        end = motion.keyframes[block[-1]].gait_end
        assert end is not None  # _gait_blocks made sure
        shortest = _shortest_period_s(motion, speed, block)
        gait = end.gait
        lines.append(
            f"{end.where}: gait: a step every {gait.period_s:g} s is faster than the joints' "
            f"velocity, acceleration and jerk limits allow: the shortest period that works is "
            + (
                f"{shortest:g} s; give period: {shortest:g} (or more), or a shorter stride or lift"
                if shortest is not None
                else f"more than {MAX_GAIT_SCALE * gait.period_s:g} s; shorten the stride or lift"
            )
        )
    return lines


MAX_GAIT_SCALE = 8.0  # a gait's period is searched up to this many times the one given
GAIT_PERIOD_STEP_S = 0.1  # the shortest period is given rounded up to this


def _shortest_period_s(motion: Motion, speed: float, block: range) -> float | None:
    """The shortest period (a multiple of ``GAIT_PERIOD_STEP_S``) at which the gait's keyframes
    all fit the limits: the gait's times scaled and planned again, by bisection."""
    end = motion.keyframes[block[-1]].gait_end
    assert end is not None
    period = end.gait.period_s

    def fits(candidate_s: float) -> bool:
        scale = candidate_s / period
        keyframes = list(motion.keyframes)
        for i in block:
            keyframes[i] = replace(keyframes[i], after_s=(keyframes[i].after_s or 0.0) * scale)
        played = played_keyframes(keyframes, repeat=motion.repeat, speed=speed)
        try:
            _Planner(motion.robot, played, False).plan()
        except _TooEarly as error:
            n = len(keyframes)
            return not any(i % n in block for i in error.messages)
        return True

    low, high = (
        math.floor(period / GAIT_PERIOD_STEP_S),
        math.ceil(MAX_GAIT_SCALE * period / GAIT_PERIOD_STEP_S),
    )
    if not fits(high * GAIT_PERIOD_STEP_S):
        return None
    while high - low > 1:  # fits(high), and low does not (the period given failed)
        middle = (low + high) // 2
        if fits(middle * GAIT_PERIOD_STEP_S):
            high = middle
        else:
            low = middle
    return round(high * GAIT_PERIOD_STEP_S, 6)


# --- public entry points -----------------------------------------------------------------------
def plan_motion(
    motion: Motion | str | os.PathLike[str], *, speed: float | None = None, stretch: bool = False
) -> PlanResult:
    """The trajectory of a whole motion (``repeat`` unrolled, times divided by the speed);
    ``motion`` may be given by its file's path.

    ``speed`` overrides ``motion.speed``. A keyframe time the limits cannot meet raises
    ``PlanningError`` starting ``path:line:col:`` (its keyframe) that names the limiting joint and
    the earliest feasible time; with ``stretch=True`` that keyframe and the later ones move
    instead, and ``PlanResult.stretches`` says by how much.
    """
    motion = motion_of(motion)
    speed = motion.speed if speed is None else check_number("speed", speed, SPEED)
    check_flag("stretch", stretch)
    robot = motion.robot
    if not motion.keyframes:
        raise PlanningError(f"{motion.path}: the motion has no keyframes")
    _check_targets(robot, motion.keyframes)
    _check_times(motion.keyframes)
    unrolled = too_many_played(len(motion.keyframes), motion.repeat)  # e.g. play --loop
    if unrolled is not None:
        raise PlanningError(f"{motion.path}: {unrolled}")
    played = played_keyframes(
        motion.keyframes,
        repeat=motion.repeat,
        speed=speed,
        repetition_at=repetition_clock(motion.music, motion.keyframes),
    )
    planner = _Planner(robot, played, stretch)
    try:
        segments, arrive, stretches = planner.plan()
    except _TooEarly as error:
        raise PlanningError(_too_early_text(motion, speed, error.messages)) from None
    trajectory = assemble(robot.joint_names, planner.positions, segments, arrive, planner.holds_s)
    for s in stretches:
        log.info("%s: stretched by %.3f s to fit the limits", s.where, s.shift_s)
    return PlanResult(trajectory, tuple(stretches))


def plan_approach(
    robot: Robot, start_deg, target_deg, limit_scale: float = APPROACH_LIMIT_SCALE
) -> Trajectory:
    """From rest at any pose ``start_deg`` to rest at ``target_deg`` (normally the first keyframe)
    with every velocity, acceleration and jerk limit scaled by ``limit_scale``.

    The start may lie outside the joint limits (it is wherever the robot is); each joint moves
    monotonically from it, so it only ever moves towards its target.
    """
    n = len(robot.joints)
    start = pose_array(robot, start_deg, "start_deg")
    target = pose_array(robot, target_deg, "target_deg")
    if not 0 < limit_scale <= 1:
        raise ValueError(f"limit_scale must be in (0, 1], got {limit_scale}")
    outside = robot.limit_violations(target.tolist())
    if outside:
        joint, angle = outside[0].joint, outside[0].angle_deg
        raise ValueError(
            f"target_deg: {joint.name} = {angle:g}° is outside its limits {joint.limits.range_text}"
        )
    zero = [0.0] * n
    low, high = segment_ranges(np.stack([start, target]))
    try:
        segment = SegmentSolver(n).solve(
            start.tolist(),
            zero,
            target.tolist(),
            zero,
            Limits.of(robot, limit_scale),
            None,
            low[0],
            high[0],
        )
    except NoTrajectory as error:
        raise PlanningError(
            "the approach to the first keyframe could not be planned: "
            + error.message(robot, start.tolist(), target.tolist())
        ) from None
    if segment.overshoot:
        raise PlanningError(
            f"internal error: the approach overshoots on "
            f"{', '.join(robot.joint_names[j] for j in segment.overshoot)}"
        )
    arrive = np.array([0.0, segment.duration_s])
    trajectory = assemble(
        robot.joint_names, np.stack([start, target]), [segment], arrive, np.zeros(2)
    )
    return Trajectory(
        trajectory.joint_names,
        trajectory.duration_s,
        (segment.duration_s,),
        trajectory.knots_s,
        trajectory.poly,
    )


def pose_array(robot: Robot, angles_deg: object, option: str) -> np.ndarray:
    """``angles_deg`` as an array: one finite angle per joint of ``robot``, in its order;
    ``OptionError`` naming ``option`` otherwise."""
    joints = f"one angle per joint ({', '.join(robot.joint_names)})"
    try:
        angles = np.asarray(angles_deg, dtype=float)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int beyond any float
        raise OptionError(option, f"needs {joints}, got {shown(angles_deg)}") from None
    if angles.shape != (len(robot.joints),):
        raise OptionError(option, f"needs {joints}, got shape {angles.shape}")
    if not np.all(np.isfinite(angles)):
        raise OptionError(option, f"must be finite, got {angles.tolist()}")
    return angles


def _check_times(keyframes: tuple[Keyframe, ...]) -> None:
    """t, after and hold inside 0..MAX_TIME_S (the loader checks this; values built in code may
    not, and a huge one overflows the sums of times)."""
    problems = [
        f"{kf.where}: {name} must be in 0..{MAX_TIME_S:g} s, got {value:g}"
        for kf in keyframes
        for name, value in (("t", kf.t_s), ("after", kf.after_s), ("hold", kf.hold_s))
        if value is not None and not 0 <= value <= MAX_TIME_S
    ]
    if problems:
        raise PlanningError(problems)


def _check_targets(robot: Robot, keyframes: tuple[Keyframe, ...]) -> None:
    """Keyframes inside the joint limits (the loader checks this; values built in code may not)."""
    n = len(robot.joints)
    wrong_size = [
        f"{kf.where}: the keyframe has {len(kf.targets_deg)} targets for {n} joints"
        for kf in keyframes
        if len(kf.targets_deg) != n
    ]
    if wrong_size:
        raise PlanningError(wrong_size)
    targets = np.array([kf.targets_deg for kf in keyframes], dtype=float)
    outside = robot.outside_limits(targets)
    problems = [
        f"{keyframes[k].where}: {robot.joints[j].name} = {targets[k, j]:g}° is outside "
        f"its limits {robot.joints[j].limits.range_text}"
        for k, j in zip(*np.nonzero(outside))
    ]
    if problems:
        raise PlanningError(problems)
