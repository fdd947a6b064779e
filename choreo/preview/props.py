"""What happened to the free props (those with a mass): where each started and ended, whether it
was lifted, dropped or knocked over, and whether it ended where the motion meant to leave it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.preview.rollout import Rollout

LIFTED_M = 0.005  # raised this far above where it rested: lifted
DROP_SPEED_M_S = 0.3  # falling faster than this after being lifted: dropped (a 5 mm fall)
KNOCKED_OVER_DEG = 30.0  # tilted more than this from how it stood at the end: knocked over
PLACE_TOLERANCE_M = 0.01  # its end this far or nearer from ``place_at_m``: placed


@dataclass(frozen=True)
class PropOutcome:
    """A free prop from the start (the robot at rest) to the end; positions are the centre of its
    bottom face in metres, as ``at_m``."""

    name: str
    start_m: tuple[float, float, float]
    end_m: tuple[float, float, float]
    lifted_m: float  # its highest rise above its start
    end_tilt_deg: float  # from how it stood at the start
    dropped_at_s: float | None  # when it fell faster than DROP_SPEED_M_S after being lifted
    place_at_m: tuple[float, float, float] | None
    place_error_m: float | None  # distance from place_at_m at the end

    @property
    def displacement_m(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end_m, self.start_m)))

    @property
    def lifted(self) -> bool:
        return self.lifted_m >= LIFTED_M

    @property
    def knocked_over(self) -> bool:
        return self.end_tilt_deg > KNOCKED_OVER_DEG

    @property
    def placed(self) -> bool | None:
        return None if self.place_error_m is None else self.place_error_m <= PLACE_TOLERANCE_M

    def to_dict(self) -> dict:
        def mm(point):
            return None if point is None else [round(1000 * v, 1) for v in point]

        return {
            "name": self.name,
            "start_mm": mm(self.start_m),
            "end_mm": mm(self.end_m),
            "displacement_mm": round(1000 * self.displacement_m, 1),
            "lifted_mm": round(1000 * self.lifted_m, 1),
            "end_tilt_deg": round(self.end_tilt_deg, 1),
            "dropped_at_s": None if self.dropped_at_s is None else round(self.dropped_at_s, 3),
            "knocked_over": self.knocked_over,
            "place_at_mm": mm(self.place_at_m),
            "place_error_mm": None
            if self.place_error_m is None
            else round(1000 * self.place_error_m, 1),
        }

    def line(self) -> str:
        """One line for the CLI."""
        start, end = (_mm_text(p) for p in (self.start_m, self.end_m))
        text = f"prop {self.name}: from [{start}] to [{end}] mm"
        text += f", moved {1000 * self.displacement_m:.0f} mm"
        text += f", lifted {1000 * self.lifted_m:.0f} mm" if self.lifted else ", never lifted"
        if self.place_error_m is not None:
            where = "at" if self.placed else "NOT at"
            text += f"; {where} its place target ({1000 * self.place_error_m:.0f} mm off)"
        return text


def _mm_text(point_m) -> str:
    return ", ".join(str(round(1000 * v)) for v in point_m)


def prop_outcomes(rollout: Rollout) -> list[PropOutcome]:
    """Every free prop's outcome, judged from the start (after settling)."""
    rollout = rollout.since_start()
    by_name = {p.name: p for p in rollout.props}
    return [
        _outcome(rollout, by_name[name], address) for name, address in rollout.prop_qpos_addresses
    ]


def _outcome(rollout: Rollout, prop, address: int) -> PropOutcome:
    qpos = rollout.qpos
    centre = qpos[:, address : address + 3]
    up = _up_axes(qpos[:, address + 3 : address + 7])
    bottom = centre - up * prop.size_m[2] / 2
    rise = bottom[:, 2] - bottom[0, 2]
    tilt = np.degrees(np.arccos(np.clip(np.sum(up[-1] * up[0]), -1.0, 1.0)))
    dropped_at = None
    lifted = np.flatnonzero(rise >= LIFTED_M)
    if len(lifted) and len(rollout.times_s) > 1:
        fall_speed = -np.gradient(centre[:, 2], rollout.times_s)
        falling = np.flatnonzero(fall_speed[lifted[0] :] > DROP_SPEED_M_S)
        if len(falling):
            dropped_at = float(rollout.times_s[lifted[0] + falling[0]])
    end = tuple(float(v) for v in bottom[-1])
    place_error = None
    if prop.place_at_m is not None:
        place_error = float(np.linalg.norm(np.subtract(end, prop.place_at_m)))
    return PropOutcome(
        name=prop.name,
        start_m=tuple(float(v) for v in bottom[0]),  # type: ignore[arg-type]
        end_m=end,  # type: ignore[arg-type]
        lifted_m=float(max(rise.max(), 0.0)),
        end_tilt_deg=float(tilt),
        dropped_at_s=dropped_at,
        place_at_m=prop.place_at_m,
        place_error_m=place_error,
    )


def _up_axes(quats: np.ndarray) -> np.ndarray:
    """(n, 3) each quaternion's (w, x, y, z) body z axis in the world."""
    w, x, y, z = quats.T
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=1)
