"""A walker in the simulation: its planned stance and where its feet and centre of mass really
were (a ``Walk``, measured from a rollout), and its gaits judged in space: the travel and turn a
``gait:`` block asked for against what the simulated body did over the block, how high the
swinging feet really rose against the commanded lift (feet that drag scuff and stumble on a
real floor), and how far inside the feet on the floor the centre of mass stayed (the static
stability margin)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.core.yaml_source import SourceLocation
from choreo.motion.gait import Gait
from choreo.preview.rollout import Rollout
from choreo.preview.stance import PLANTED_M, PlannedStance, support_margin

TRAVEL_WARNING_FRACTION = 0.75  # travel or turn below this share of the asked: a warning
LIFT_WARNING_FRACTION = 0.5  # swinging feet rising less than this share of the lift: dragging
_MARGIN_SAMPLE_S = 0.02  # the stability margin is measured this often


@dataclass(frozen=True)
class GaitDue:
    """A played ``gait:`` block: from the arrival of the keyframe before it to its last one."""

    start_s: float
    end_s: float
    gait: Gait
    where: SourceLocation


@dataclass(frozen=True)
class Walk:
    """A walker (a free-floating robot with foot sites) step by step, the rollout's steps: the
    plan's stance, where its foot sites and its centre of mass really were, and the ``gait:``
    blocks it played."""

    stance: PlannedStance | None  # None: fewer than three feet, no plane to stand on
    foot_m: np.ndarray  # (n, feet, 3) the foot sites in the world, stance order
    centre_of_mass_m: np.ndarray  # (n, 3) the robot's, in the world
    gaits: tuple[GaitDue, ...] = ()

    def since(self, k: int) -> Walk:
        return Walk(
            None if self.stance is None else self.stance.since(k),
            self.foot_m[k:],
            self.centre_of_mass_m[k:],
            self.gaits,
        )


@dataclass(frozen=True)
class GaitOutcome:
    where: SourceLocation
    asked_mm: tuple[float, float]  # forward, left: steps x stride, steps x sideways
    asked_turn_deg: float
    got_mm: tuple[float, float]  # in the body's frame at the start of the block
    got_turn_deg: float
    lift_mm: float  # asked
    lift_fraction: float | None  # mean over swings of the highest rise / the asked lift
    # the least distance of the centre of mass inside the polygon of the feet the plan has
    # down, seen from above (negative: outside it)
    margin_mm: float | None = None

    @property
    def travel_fraction(self) -> float | None:
        """The achieved travel along the asked direction, as a share of the asked distance."""
        asked = np.hypot(*self.asked_mm)
        if asked < 1.0:
            return None
        return float(np.dot(self.got_mm, self.asked_mm) / asked**2)

    @property
    def turn_fraction(self) -> float | None:
        if abs(self.asked_turn_deg) < 1.0:
            return None
        return self.got_turn_deg / self.asked_turn_deg

    def line(self) -> str:
        parts = []
        if self.travel_fraction is not None:
            parts.append(
                f"travelled {np.hypot(*self.got_mm):.0f} of {np.hypot(*self.asked_mm):.0f} mm "
                f"({100 * self.travel_fraction:.0f} % along the asked direction)"
            )
        if self.turn_fraction is not None:
            parts.append(
                f"turned {self.got_turn_deg:+.0f} of {self.asked_turn_deg:+.0f}° "
                f"({100 * self.turn_fraction:.0f} %)"
            )
        if self.lift_fraction is not None:
            parts.append(
                f"swinging feet rose {100 * self.lift_fraction:.0f} % of the "
                f"{self.lift_mm:g} mm lift"
            )
        if self.margin_mm is not None:
            parts.append(f"centre of mass at least {self.margin_mm:.0f} mm inside the feet down")
        return f"gait at {self.where}: " + ", ".join(parts or ["stood still, as asked"])

    def to_dict(self) -> dict:
        def share(value):
            return None if value is None else round(100 * value, 1)

        return {
            "line": str(self.where),
            "asked_mm": [round(v, 1) for v in self.asked_mm],
            "got_mm": [round(v, 1) for v in self.got_mm],
            "travel_pct": share(self.travel_fraction),
            "asked_turn_deg": round(self.asked_turn_deg, 1),
            "got_turn_deg": round(self.got_turn_deg, 1),
            "turn_pct": share(self.turn_fraction),
            "lift_mm": self.lift_mm,
            "lift_pct": share(self.lift_fraction),
            "margin_mm": None if self.margin_mm is None else round(self.margin_mm, 1),
        }


def gait_outcomes(rollout: Rollout, walk: Walk | None) -> list[GaitOutcome]:
    """Each ``gait:`` block of ``walk`` (measured on ``rollout``) against what it asked."""
    if rollout.body is None or walk is None:
        return []
    address = rollout.body.qpos_address
    out = []
    for due in walk.gaits:
        first, last = (
            min(int(np.searchsorted(rollout.times_s, t - 1e-9)), len(rollout.times_s) - 1)
            for t in (due.start_s, due.end_s)
        )
        x, y, heading = _floor_pose(rollout.qpos[[first, last]], address)
        dx, dy = x[1] - x[0], y[1] - y[0]
        c, s = np.cos(heading[0]), np.sin(heading[0])
        gait = due.gait
        out.append(
            GaitOutcome(
                where=due.where,
                asked_mm=(gait.steps * gait.stride_mm, gait.steps * gait.sideways_mm),
                asked_turn_deg=gait.steps * gait.turn_deg,
                got_mm=(1000 * (c * dx + s * dy), 1000 * (-s * dx + c * dy)),
                got_turn_deg=float(np.degrees(_turn(rollout, address, first, last))),
                lift_mm=gait.lift_mm,
                lift_fraction=_lift_fraction(walk, first, last, gait.lift_mm / 1000),
                margin_mm=_margin_mm(rollout, walk, first, last),
            )
        )
    return out


def _floor_pose(qpos: np.ndarray, address: int):
    w, x, y, z = (qpos[:, address + 3 + i] for i in range(4))
    heading = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return qpos[:, address], qpos[:, address + 1], heading


def _turn(rollout: Rollout, address: int, first: int, last: int) -> float:
    """The heading's change over the steps, unwrapped (whole turns counted)."""
    _, _, heading = _floor_pose(rollout.qpos[first : last + 1 : 10], address)
    _, _, end = _floor_pose(rollout.qpos[[last]], address)
    heading = np.unwrap(np.r_[heading, end])
    return float(heading[-1] - heading[0])


def _lift_fraction(walk: Walk, first: int, last: int, lift_m: float) -> float | None:
    """Over every swing of every foot in the block (the plan lifting it 1 mm or more, and at
    its highest half the gait's lift or more): its highest rise over its height at the block's
    start, as a share of the lift the gait asked (the plan may lift it higher, making up for
    the robot's sag: the robot file's ``gait: lift_sag``)."""
    stance = walk.stance
    if stance is None or lift_m <= 0:
        return None
    heights = walk.foot_m[:, :, 2]
    shares = []
    for foot in range(stance.lift_m.shape[1]):
        planned = stance.lift_m[first : last + 1, foot]
        rise = heights[first : last + 1, foot] - heights[first, foot]
        swinging = np.concatenate(([False], planned >= 0.001, [False])).astype(np.int8)
        edges = np.flatnonzero(np.diff(swinging))
        for begin, end in zip(edges[::2], edges[1::2]):
            if planned[begin:end].max() < lift_m / 2:
                continue  # the plan's floor shifting under a planted foot, not a swing
            shares.append(float(rise[begin:end].max() / lift_m))
    return float(np.mean(shares)) if shares else None


def _margin_mm(rollout: Rollout, walk: Walk, first: int, last: int) -> float | None:
    """The least, over the block, of how far the centre of mass stands inside the polygon of
    the feet (where they really are) that the plan has on the floor, seen from above."""
    stance, feet, centre = walk.stance, walk.foot_m, walk.centre_of_mass_m
    if stance is None:
        return None
    dt = float(rollout.times_s[1] - rollout.times_s[0]) if len(rollout.times_s) > 1 else 1.0
    margins = [
        support_margin(feet[step, down, :2], centre[step, :2])
        for step in range(first, last + 1, max(1, round(_MARGIN_SAMPLE_S / dt)))
        if (down := stance.lift_m[step] < PLANTED_M).sum() >= 3
    ]
    return 1000 * min(margins) if margins else None
