"""The planned stance of a walker: from the commanded joint angles alone (no physics), which
feet the plan has on the floor, how high each other foot is lifted, and where the body should
be over the floor, so the checks can judge the simulated body against its plan.

The floor under the plan is the plane of its planted feet, found from the foot sites (the MJCF's
``choreo:feet``) in the base frame: a plane fitted to all feet, then refitted to those not more
than ``PLANTED_M`` above it, until it settles. With three or more planted feet that is the tilt
the plan gives the body (``body: {roll: 6}``); with fewer, the plan is a level body over its
lowest feet (and cannot stand: the body will come down, which the checks report).

That fit reads any feet that can share a plane as planted, so four feet raised 15 mm would
read as the body tilted over the four corner feet, and the robot tipping onto them as the
plan. So a keyframe decides, from its targets (``floors_kept``): one written as ``body:`` may
tilt the floor; any other (a raw ``pose:``, ``sites:``, a gait's step) keeps the floor's tilt
unless every foot planted at the keyframe before still shares a plane (a body rocked by its
legs, all six feet down). Moving towards a keyframe that keeps it, the floor is that plane under
the lowest feet, and the feet the plan raises off it are lifted, as the motion says: the checks
compare that with the feet really on the ground.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.preview.model import link_name, link_of_body
from choreo.preview.step_loop import as_slice
from choreo.robot.kinematics import Kinematics

PLANTED_M = 0.003  # a foot this close above the planned floor is on it
SAMPLE_S = 0.02  # the plan is evaluated this often (and interpolated between)
_FIT_ROUNDS = 4


@dataclass(frozen=True)
class PlannedStance:
    """Per physics step (the rollout's steps): the plan's body height above its floor (m), the
    floor's upward normal in the base frame, and each foot's lift above that floor (m)."""

    foot_links: tuple[str, ...]  # the link each foot site belongs to (the scene model's names)
    height_m: np.ndarray  # (n,)
    up_base: np.ndarray  # (n, 3)
    lift_m: np.ndarray  # (n, feet)

    def since(self, k: int) -> PlannedStance:
        return PlannedStance(self.foot_links, self.height_m[k:], self.up_base[k:], self.lift_m[k:])


def floors_kept(
    kin: Kinematics, targets_deg: Sequence[Sequence[float]], tilts: Sequence[bool]
) -> list[np.ndarray | None]:
    """Per played keyframe (its joint targets; ``tilts``: written as ``body:``): the floor's
    upward normal (base frame) the plan keeps moving towards it, or None where the plan may
    tilt the floor (the fit)."""
    feet = kin.feet()
    kept: list[np.ndarray | None] = []
    planted, normal = None, np.array([0.0, 0.0, 1.0])
    feet_m = np.array([_feet_m(kin, feet, targets) for targets in targets_deg])
    _, fitted_normals, fitted_lifts = _floors(feet_m.reshape(-1, len(feet), 3))  # at once
    for points, tilt, fitted_normal, fitted_lift in zip(
        feet_m, tilts, fitted_normals, fitted_lifts
    ):
        if planted is None or tilt or _one_plane(points[planted]):
            kept.append(None)
            normal, lift = fitted_normal, fitted_lift
        else:
            kept.append(normal)
            _, _, lift = _floor_along(points, normal)
        planted = lift <= PLANTED_M
    return kept


def _one_plane(points: np.ndarray) -> bool:
    """Three or more points within ``PLANTED_M`` of one plane."""
    if len(points) < 3:
        return False
    normal, offset = _plane(points)
    return bool(np.abs(points @ normal + offset).max() <= PLANTED_M)


def _feet_m(kin: Kinematics, feet: Sequence[str], angles_deg) -> np.ndarray:
    return kin.site_positions_mm(feet, angles_deg) / 1000


def planned_stance(
    kin: Kinematics,
    model: mujoco.MjModel,
    command_deg: np.ndarray,
    times_s: np.ndarray,
    kept: Sequence[np.ndarray | None] | None = None,
) -> PlannedStance | None:
    """The plan's stance along ``command_deg`` (robot joint order, one row per step), or None
    for a robot without foot sites. ``kept``: per step, the floor's normal the plan keeps
    there (``floors_kept``, of the keyframe it heads for), or None where it may tilt it;
    None: it may everywhere."""
    feet = kin.feet()
    if len(feet) < 3 or not len(times_s):
        return None
    dt = float(times_s[1] - times_s[0]) if len(times_s) > 1 else SAMPLE_S
    every = max(1, round(SAMPLE_S / dt))
    samples = np.unique(np.r_[np.arange(0, len(times_s), every), len(times_s) - 1])
    points = np.array([_feet_m(kin, feet, command_deg[step]) for step in samples])
    normals = [None if kept is None else kept[step] for step in samples]
    # the samples whose floor is fitted are fitted together (``_floors``), the others one by one
    fitted = np.array([normal is None for normal in normals], dtype=bool)
    heights, ups, lifts = (
        np.empty(len(samples)),
        np.empty((len(samples), 3)),
        np.empty(points.shape[:2]),
    )
    heights[fitted], ups[fitted], lifts[fitted] = _floors(points[fitted])
    for sample, normal in enumerate(normals):
        if normal is not None:
            heights[sample], ups[sample], lifts[sample] = _floor_along(points[sample], normal)
    at = times_s[samples]
    links = link_of_body(model)
    foot_links = tuple(
        link_name(model, int(links[model.site_bodyid[model.site(foot).id]])) for foot in feet
    )
    nearest = np.clip(np.searchsorted(at, times_s), 0, len(at) - 1)
    return PlannedStance(
        foot_links=foot_links,
        height_m=np.interp(times_s, at, heights),
        up_base=ups[nearest],
        lift_m=np.stack([np.interp(times_s, at, column) for column in lifts.T], axis=1),
    )


def _floors(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planted feet's plane under each of ``points`` (samples, feet, 3; base frame, m): the
    base origin's height above it, its upward normal, and each foot's height above it. A plane
    fitted to all feet, then refitted to those not more than ``PLANTED_M`` above it, until it
    settles. The samples planting the same feet in a round are fitted together (``_planes``):
    the thousands of samples of a walk have a handful of such sets, and numpy's cost is per
    call."""
    n, feet = points.shape[:2]
    planted = np.ones((n, feet), dtype=bool)
    normal, offset = np.zeros((n, 3)), np.zeros(n)  # each sample's is fitted in the first round
    fitting = np.arange(n)
    for _ in range(_FIT_ROUNDS):
        if not len(fitting):
            break
        for feet_down, rows in _by_row(planted[fitting]):
            at = fitting[rows]
            normal[at], offset[at] = _planes(points[at][:, feet_down])
        above = _above(points[fitting], normal[fitting], offset[fitting])
        # the lowest feet stay planted: a fit through feet at different heights lies between them
        lowest = np.maximum(PLANTED_M, above.min(axis=1) + PLANTED_M)
        now = above <= lowest[:, None]
        settled = (now == planted[fitting]).all(axis=1)
        planted[fitting[~settled]] = now[~settled]
        fitting = fitting[~settled]
    above = _above(points, normal, offset)
    on_floor = np.empty(n)
    for feet_down, rows in _by_row(planted):
        on_floor[rows] = above[rows][:, feet_down].mean(axis=1)
    lift = above - on_floor[:, None]
    return offset + 0.0 - on_floor, normal, np.maximum(lift, 0.0)


def _by_row(masks: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The distinct rows of ``masks`` (boolean), each with the indices of the rows equal to it."""
    codes = masks @ (1 << np.arange(masks.shape[1]))  # a row's bits as one number
    distinct, first, which = np.unique(codes, return_index=True, return_inverse=True)
    return [(masks[row], np.flatnonzero(which == k)) for k, row in enumerate(first)]


def _above(points: np.ndarray, normal: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Each point's height above its sample's plane n·p + d = 0 (samples, feet)."""
    return np.matmul(points, normal[:, :, None])[:, :, 0] + offset[:, None]


def _floor_along(points: np.ndarray, normal: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """As ``_floors`` for one sample, with the floor's upward ``normal`` kept: the plane under
    the lowest feet."""
    above = points @ normal
    lift = above - float(above.min())
    planted = lift <= PLANTED_M
    return float(-above[planted].mean()), normal, lift


def _plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The plane n·p + d = 0 through ``points`` (n pointing up the base z): least squares for three
    or more that span a plane; level through their mean otherwise."""
    normal, offset = _planes(points[None])
    return normal[0], float(offset[0])


def _planes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``_plane`` through each of ``points`` (samples, points, 3) at once."""
    centre = points.mean(axis=1)
    normal, offset = np.zeros((len(points), 3)), -centre[:, 2]
    normal[:, 2] = 1.0
    if points.shape[1] >= 3:
        _, singular, vt = np.linalg.svd(points - centre[:, None, :])
        spans = singular[:, 1] > 1e-3  # not all on one line
        fitted = vt[spans, 2]
        fitted[fitted[:, 2] <= 0] *= -1
        normal[spans] = fitted
        offset[spans] = -np.matmul(fitted[:, None, :], centre[spans, :, None])[:, 0, 0]
    return normal, offset


def feet_and_centre(
    kin: Kinematics, model: mujoco.MjModel, qpos: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """At every recorded state: each foot site's position (n, feet, 3) and the robot's centre of
    mass (n, 3), in the world (m)."""
    data = mujoco.MjData(model)
    ids = np.array([model.site(foot).id for foot in kin.feet()], dtype=int)
    sites = as_slice(ids)  # consecutive, as usual: a view per state, not a gather
    root = model.body(kin.base_body).id
    feet, centre = np.empty((len(qpos), len(ids), 3)), np.empty((len(qpos), 3))
    # MjData's arrays never move: taken once, not at each of the (thousands of) states
    positions, site_xpos, subtree_com = data.qpos, data.site_xpos, data.subtree_com
    kinematics, com = mujoco.mj_kinematics, mujoco.mj_comPos
    for step, state in enumerate(qpos):
        positions[:] = state
        kinematics(model, data)
        com(model, data)
        feet[step] = site_xpos[sites]
        centre[step] = subtree_com[root]
    return feet, centre


def support_margin(feet_xy: np.ndarray, point_xy: np.ndarray) -> float:
    """How far ``point_xy`` lies inside the convex polygon around ``feet_xy`` (negative: outside
    by that much): its distance to the nearest edge, for three or more feet. In Python floats,
    not numpy: it is asked at every sample of a walk, for a handful of feet."""
    hull = _convex_hull(np.asarray(feet_xy, dtype=float).tolist())
    x, y = (float(value) for value in point_xy)
    distances = []
    for (ax, ay), (bx, by) in zip(hull, hull[1:] + hull[:1]):
        ex, ey = bx - ax, by - ay
        length = math.sqrt(ex * ex + ey * ey)
        if length > 1e-12:
            # counter-clockwise: a point inside is to the left of every edge
            distances.append((ex * (y - ay) - ey * (x - ax)) / length)
    return min(distances)


def _convex_hull(points: list[list[float]]) -> list[tuple[float, ...]]:
    """The hull's corners, counter-clockwise (Andrew's monotone chain)."""
    ordered = sorted(map(tuple, points))

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(sequence):
        chain: list[tuple[float, ...]] = []
        for point in sequence:
            while len(chain) >= 2 and cross(chain[-2], chain[-1], point) <= 0:
                chain.pop()
            chain.append(point)
        return chain[:-1]

    return half(ordered) + half(reversed(ordered))
