"""How a free-floating robot comes down: each time a link other than a foot begins to touch the
ground (the floor or a fixed prop), which link it is and how fast it was moving just before.

A robot that lies down as it means to (``end: lying``) lowers its body onto the floor at a few
centimetres a second; one that topples free-falls onto it at a metre a second or more. Where it
ends can be the same; the speed at impact tells them apart (and is what breaks a servo horn).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.preview.model import link_of_body
from choreo.preview.rollout import Rollout

BEFORE_S = 0.01  # the speed at impact is measured over this long before the touch
IMPACT_SPEED_M_S = 0.5  # faster than this onto the ground: a fall (a free fall of 13 mm)


@dataclass(frozen=True)
class Impact:
    """A link beginning to touch the ground: when, and how fast its lowest part was moving
    just before (m/s)."""

    link: str
    ground: str  # the floor, or a fixed prop's name
    time_s: float
    speed_m_s: float

    @property
    def fall_height_m(self) -> float:
        """The free fall that ends at this speed."""
        return self.speed_m_s**2 / (2 * 9.81)

    def to_dict(self) -> dict:
        return {
            "link": self.link,
            "ground": self.ground,
            "time_s": round(self.time_s, 4),
            "speed_m_s": round(self.speed_m_s, 3),
        }


def impacts(rollout: Rollout, model: mujoco.MjModel, from_s: float = -np.inf) -> list[Impact]:
    """Every link other than a foot beginning to touch the ground at ``from_s`` or later (the
    rollout from its start: touches the robot rests on at the start are not impacts), in time
    order. ``model``: the rollout's scene (``model.load_model``)."""
    rollout = rollout.since_start()
    times, contacts = rollout.times_s, rollout.contacts
    links = link_of_body(model)
    data = mujoco.MjData(model)
    dt = float(times[1] - times[0]) if len(times) > 1 else 0.0
    back = max(1, round(BEFORE_S / dt)) if dt else 1
    found = []
    for pair_index, pair in enumerate(contacts.pairs):
        if pair.kind != "ground":
            continue
        touching, _ = contacts.mask(pair_index, len(times))
        begins = np.flatnonzero(touching & ~np.r_[True, touching[:-1]])  # not at the start
        link = model.body(pair.body_a).id
        geoms = np.flatnonzero(links[model.geom_bodyid] == link)
        for step in begins:
            if times[step] < from_s:
                continue
            first = max(int(step) - back, 0)
            before, now = (
                _geom_positions(model, data, rollout.qpos[k], geoms) for k in (first, step)
            )
            lowest = int(np.argmin(now[:, 2]))
            moved = float(np.linalg.norm(now[lowest] - before[lowest]))
            speed = moved / float(times[step] - times[first])
            found.append(Impact(pair.body_a, pair.body_b, float(times[step]), speed))
    return sorted(found, key=lambda impact: impact.time_s)


def _geom_positions(
    model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray, geoms: np.ndarray
) -> np.ndarray:
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return data.geom_xpos[geoms].copy()
