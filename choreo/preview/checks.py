"""Judging a rollout: what would go wrong on the robot, with joint/body names and times.

Each check turns a recorded signal into episodes (runs of steps where something is wrong, short
gaps merged) and reports one ``CheckResult`` per episode, at the time it starts.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from enum import Enum

import numpy as np

from .sim import Rollout


class Severity(str, Enum):
    ERROR = "error"  # the motion should not be played as it is
    WARNING = "warning"  # worth a look


class CheckKind(str, Enum):
    SELF_COLLISION = "self_collision"
    FLOOR_CONTACT = "floor_contact"
    JOINT_LIMIT = "joint_limit"
    SATURATION = "saturation"
    TRACKING_ERROR = "tracking_error"
    FALL = "fall"


@dataclass(frozen=True)
class CheckResult:
    kind: CheckKind
    severity: Severity
    message: str  # one line, names and time included
    time_s: float  # when it starts, from the motion start
    duration_s: float = 0.0
    joint: str | None = None
    bodies: tuple[str, ...] = ()
    value: float | None = None  # the worst value seen, in the unit the message gives

    def to_dict(self) -> dict:
        record = asdict(self)
        record.update(
            kind=self.kind.value,
            severity=self.severity.value,
            bodies=list(self.bodies),
            time_s=round(self.time_s, 4),
            duration_s=round(self.duration_s, 4),
        )
        if self.value is not None:
            record["value"] = round(self.value, 4)
        return record


@dataclass(frozen=True)
class CheckThresholds:
    max_tracking_error_deg: float = 10.0  # joint angle vs the path the ticks ask for
    tracking_error_after_s: float = 0.5  # longer than this: an error, shorter: lag (a warning)
    stall_after_s: float = 0.25  # torque at the servo's limit longer than this = a stall
    saturation_fraction: float = 0.98  # |torque| >= this * stall torque counts as saturated
    limit_margin_deg: float = 0.5  # this close to a joint limit counts as touching it
    fall_height_fraction: float = 0.5  # free-floating body below this * its start height
    fall_tilt_deg: float = 30.0  # ... or tilted more than this from upright
    merge_gap_s: float = 0.05  # episodes closer than this are one

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value!r}")
        if not 0 < self.saturation_fraction <= 1:
            raise ValueError(
                f"saturation_fraction must be in (0, 1], got {self.saturation_fraction}"
            )


def run_checks(
    rollout: Rollout, thresholds: CheckThresholds = CheckThresholds()
) -> list[CheckResult]:
    """Every problem found, in time order."""
    results = [
        *check_contacts(rollout, thresholds),
        *check_joint_limits(rollout, thresholds),
        *check_saturation(rollout, thresholds),
        *check_tracking(rollout, thresholds),
        *check_fall(rollout, thresholds),
    ]
    return sorted(results, key=lambda r: (r.time_s, r.kind.value, r.joint or "", r.bodies))


def episodes(mask: np.ndarray, merge_gap_steps: int) -> list[tuple[int, int]]:
    """Runs of True as [start, end) index pairs; runs separated by at most ``merge_gap_steps``
    False steps are merged."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    runs = list(zip(edges[::2].tolist(), edges[1::2].tolist()))
    merged: list[tuple[int, int]] = []
    for start, end in runs:
        if merged and start - merged[-1][1] <= merge_gap_steps:
            merged[-1] = (merged[-1][0], end)
        else:
            merged.append((start, end))
    return merged


class _Timeline:
    """Step indices <-> times for messages."""

    def __init__(self, rollout: Rollout, thresholds: CheckThresholds):
        self.times = rollout.times_s
        self.dt = float(self.times[1] - self.times[0]) if len(self.times) > 1 else 0.0
        self.merge_steps = round(thresholds.merge_gap_s / self.dt) if self.dt else 0

    def episodes(self, mask: np.ndarray) -> list[tuple[int, int]]:
        return episodes(mask, self.merge_steps)

    def start(self, run: tuple[int, int]) -> float:
        return float(self.times[run[0]])

    def duration(self, run: tuple[int, int]) -> float:
        return (run[1] - run[0]) * self.dt


def check_contacts(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    timeline = _Timeline(rollout, thresholds)
    results = []
    for pair_index, pair in enumerate(rollout.contact_pairs):
        mine = rollout.contact_pair == pair_index
        mask = np.zeros(len(rollout.times_s), dtype=bool)
        mask[rollout.contact_step[mine]] = True
        depth_by_step = np.zeros(len(rollout.times_s))
        np.maximum.at(depth_by_step, rollout.contact_step[mine], rollout.contact_depth_m[mine])
        for run in timeline.episodes(mask):
            depth_mm = 1000 * float(depth_by_step[run[0] : run[1]].max())
            when = f"at t={timeline.start(run):.2f} s for {timeline.duration(run):.2f} s"
            if pair.kind == "self":
                kind = CheckKind.SELF_COLLISION
                message = f"self-collision: {pair.body_a} hits {pair.body_b} {when}"
            else:
                kind = CheckKind.FLOOR_CONTACT
                message = f"{pair.body_a} touches the {pair.body_b} {when}"
            results.append(
                CheckResult(
                    kind,
                    Severity.ERROR,
                    f"{message} (up to {depth_mm:.1f} mm deep)",
                    timeline.start(run),
                    timeline.duration(run),
                    bodies=(pair.body_a, pair.body_b),
                    value=depth_mm,
                )
            )
    return results


def check_joint_limits(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    """A joint at a limit while its servo aims past it (error: it pushes against the stop), or
    carried past it by its own momentum or the load (warning)."""
    timeline = _Timeline(rollout, thresholds)
    margin = thresholds.limit_margin_deg
    results = []
    for j, joint in enumerate(rollout.robot.joints):
        q, aim = rollout.position_deg[:, j], rollout.setpoint_deg[:, j]
        for side, limit, sign in (
            ("min", joint.limits.min_deg, -1),
            ("max", joint.limits.max_deg, 1),
        ):
            past_q = sign * (q - limit)  # > 0: beyond the limit
            past_aim = sign * (aim - limit)
            at_limit = past_q > -margin
            pushing = at_limit & (past_aim > margin)
            overshoot = at_limit & (past_q > margin)
            for run in timeline.episodes(pushing | overshoot):
                span = slice(*run)
                start, duration = timeline.start(run), timeline.duration(run)
                if pushing[span].any():
                    worst = float(limit + sign * past_aim[span].max())
                    results.append(
                        CheckResult(
                            CheckKind.JOINT_LIMIT,
                            Severity.ERROR,
                            f"{joint.name} hits its {side} limit {limit:g}° at t={start:.2f} s and "
                            f"its servo pushes on towards {worst:.1f}° for {duration:.2f} s",
                            start,
                            duration,
                            joint=joint.name,
                            value=worst,
                        )
                    )
                else:
                    worst = float(limit + sign * past_q[span].max())
                    results.append(
                        CheckResult(
                            CheckKind.JOINT_LIMIT,
                            Severity.WARNING,
                            f"{joint.name} runs into its {side} limit {limit:g}° at t={start:.2f} s "
                            f"(reaching {worst:.1f}°) for {duration:.2f} s",
                            start,
                            duration,
                            joint=joint.name,
                            value=worst,
                        )
                    )
    return results


def check_saturation(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    timeline = _Timeline(rollout, thresholds)
    stall = rollout.stall_torque_nm
    saturated = np.abs(rollout.torque_nm) >= thresholds.saturation_fraction * stall
    results = []
    for j, joint in enumerate(rollout.robot.joints):
        for run in timeline.episodes(saturated[:, j]):
            start, duration = timeline.start(run), timeline.duration(run)
            if duration < thresholds.stall_after_s:
                continue
            results.append(
                CheckResult(
                    CheckKind.SATURATION,
                    Severity.ERROR,
                    f"{joint.name} servo at its {stall[j]:.2f} N·m torque limit for {duration:.2f} s "
                    f"from t={start:.2f} s: it would stall (too fast for the load, or the load too "
                    f"heavy)",
                    start,
                    duration,
                    joint=joint.name,
                    value=float(stall[j]),
                )
            )
    return results


def check_tracking(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    timeline = _Timeline(rollout, thresholds)
    error = np.abs(rollout.position_deg - rollout.command_deg)
    limit = thresholds.max_tracking_error_deg
    results = []
    for j, joint in enumerate(rollout.robot.joints):
        for run in timeline.episodes(error[:, j] > limit):
            start, duration = timeline.start(run), timeline.duration(run)
            worst = float(error[run[0] : run[1], j].max())
            lasting = duration >= thresholds.tracking_error_after_s
            results.append(
                CheckResult(
                    CheckKind.TRACKING_ERROR,
                    Severity.ERROR if lasting else Severity.WARNING,
                    f"{joint.name} is {worst:.1f}° off its commanded path (more than {limit:g}°) "
                    f"from t={start:.2f} s for {duration:.2f} s",
                    start,
                    duration,
                    joint=joint.name,
                    value=worst,
                )
            )
    return results


def check_fall(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    if rollout.root_height_m is None or rollout.root_tilt_deg is None:
        return []
    start_height = float(rollout.root_height_m[0])
    low = rollout.root_height_m < thresholds.fall_height_fraction * start_height
    tilted = rollout.root_tilt_deg > thresholds.fall_tilt_deg
    fallen = np.flatnonzero(low | tilted)
    if not len(fallen):
        return []
    step = int(fallen[0])
    t = float(rollout.times_s[step])
    height, tilt = float(rollout.root_height_m[step]), float(rollout.root_tilt_deg[step])
    why = (
        f"its height drops to {height:.3f} m (from {start_height:.3f} m)"
        if low[step]
        else f"it tilts {tilt:.0f}° from upright"
    )
    return [
        CheckResult(
            CheckKind.FALL,
            Severity.ERROR,
            f"{rollout.root_body} falls at t={t:.2f} s: {why}",
            t,
            bodies=(rollout.root_body or "",),
            value=tilt if not low[step] else height,
        )
    ]
