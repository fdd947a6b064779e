"""Where a free-floating robot's body went: start and end position and heading, distance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.preview.rollout import Rollout

_PATH_SAMPLE_S = 0.05  # path length from the body's position every 50 ms: sway, not vibration


@dataclass(frozen=True)
class BodyTravel:
    body: str
    start_mm: tuple[float, float, float]  # world frame
    end_mm: tuple[float, float, float]
    start_heading_deg: float  # direction of the body's x axis on the floor, from world x
    end_heading_deg: float
    turned_deg: float  # counter-clockwise seen from above, counting whole turns
    displacement_mm: float  # start to end on the floor
    path_mm: float  # along the way, on the floor

    def to_dict(self) -> dict:
        return {
            key: [round(v, 1) + 0.0 for v in value] if isinstance(value, tuple) else value
            for key, value in vars(self).items()
        }


def body_travel(rollout: Rollout) -> BodyTravel | None:
    """The root body's travel from the start (after settling, as the checks judge it) to the
    end of the rollout, or None for a robot fixed to the world."""
    rollout = rollout.since_start()
    if rollout.body is None or not len(rollout.times_s):
        return None
    address = rollout.body.qpos_address
    position_mm = rollout.qpos[:, address : address + 3] * 1000
    w, x, y, z = (rollout.qpos[:, address + 3 + i] for i in range(4))
    heading = np.unwrap(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
    dt = float(rollout.times_s[1] - rollout.times_s[0]) if len(rollout.times_s) > 1 else 1.0
    stride = max(1, round(_PATH_SAMPLE_S / dt))
    floor = np.vstack([position_mm[::stride, :2], position_mm[-1:, :2]])
    start, end = position_mm[0], position_mm[-1]
    return BodyTravel(
        body=rollout.body.name,
        start_mm=_rounded(start),
        end_mm=_rounded(end),
        start_heading_deg=_heading_deg(heading[0]),
        end_heading_deg=_heading_deg(heading[-1]),
        turned_deg=round(float(np.degrees(heading[-1] - heading[0])), 1),
        displacement_mm=round(float(np.linalg.norm(end[:2] - start[:2])), 1),
        path_mm=round(float(np.linalg.norm(np.diff(floor, axis=0), axis=1).sum()), 1),
    )


def _heading_deg(radians: float) -> float:
    """-180 < heading <= 180, rounded, with no -0."""
    degrees = -((180.0 - np.degrees(radians)) % 360.0) + 180.0
    return round(float(degrees), 1) + 0.0


def _rounded(mm: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (round(float(v), 1) + 0.0 for v in mm)  # + 0.0: no "-0.0"
    return x, y, z
