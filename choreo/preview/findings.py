"""What the preview's checks report: a finding (``CheckResult``) of a kind and severity, at a
time, naming joints and bodies; the thresholds they judge by; and the episodes (runs of steps where
something is wrong, short gaps merged) each check turns its signal into."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from enum import Enum

import numpy as np

from choreo.core.arguments import NON_NEGATIVE, Range, check_number
from choreo.preview.rollout import Rollout


class Severity(str, Enum):
    ERROR = "error"  # the motion should not be played as it is
    WARNING = "warning"  # worth a look


class CheckKind(str, Enum):
    SELF_COLLISION = "self_collision"
    FLOOR_CONTACT = "floor_contact"
    NEIGHBOUR_CONTACT = "neighbour_contact"  # parent and child links MuJoCo lets collide
    JOINT_LIMIT = "joint_limit"
    SATURATION = "saturation"  # a stall: torque at the limit and the joint nearly still
    CANT_KEEP_UP = "cant_keep_up"  # torque at the limit while moving: it lags
    NEAR_MISS = "near_miss"  # torque close to the limit for a while
    TRACKING_ERROR = "tracking_error"
    FALL = "fall"
    REACH = "reach"  # a sites: target not reached: the site too far from it when due
    GAIT = "gait"  # a gait: block travelling or turning short of what it asked, or feet dragging
    JOINT_JUMP = "joint_jump"  # a small move in space that IK meets with a large joint move
    PROP = "prop"  # a free prop dropped, knocked over, or not left where the motion meant to
    SUPPLY = "supply"  # the servos' supply outside their rated range: play refuses it


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


FRACTION = Range(above=0, at_most=1)


@dataclass(frozen=True)
class CheckThresholds:
    max_tracking_error_deg: float = 10.0  # joint angle vs the path the ticks ask for
    tracking_error_after_s: float = 0.5  # longer than this: an error, shorter: lag (a warning)
    stall_after_s: float = 0.25  # torque at the limit and nearly still this long = a stall
    saturation_fraction: float = 0.98  # |torque| >= this * stall torque counts as saturated
    stall_speed_fraction: float = 0.1  # "nearly still": slower than this * no-load speed
    near_miss_fraction: float = 0.8  # |torque| >= this * stall torque is a near miss ...
    near_miss_after_s: float = 0.1  # ... when it lasts this long, or adds up to it ...
    near_miss_window_s: float = 1.0  # ... within this long (short pushes, one after another)
    limit_margin_deg: float = 0.5  # this close to a joint limit counts as touching it
    fall_height_fraction: float = 0.5  # free-floating body below this * its start height
    fall_tilt_deg: float = 30.0  # ... or tilted more than this from upright (once upright)
    stumble_drop_mm: float = 5.0  # a walker's body this much lower than its plan puts it ...
    stumble_tilt_deg: float = 3.0  # ... or tilted this much more than planned: a stumble
    stumble_lift_mm: float = 10.0  # a foot on the floor that the plan has this high: a stumble
    merge_gap_s: float = 0.05  # episodes closer than this are one

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            fraction = name.endswith("_fraction")  # a share of a figure: above 0, at most all of it
            check_number(name, value, FRACTION if fraction else NON_NEGATIVE)


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


class Timeline:
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
