"""The body's checks: a fall (and how a robot that means to lie down comes down: its landing and
which way up it ends), stumbles against the planned stance, and lifted feet that came down."""

from __future__ import annotations

import numpy as np

from choreo.preview.findings import CheckKind, CheckResult, CheckThresholds, Severity, Timeline
from choreo.preview.impact import IMPACT_SPEED_M_S
from choreo.preview.rollout import Rollout
from choreo.preview.simulated import SimulatedMotion


def check_fall(simulated: SimulatedMotion, thresholds: CheckThresholds) -> list[CheckResult]:
    """A free-floating robot falling or collapsing after its start (the robot at rest before the
    approach): a link other than a foot touching the ground when it did not at the start, its
    body below ``fall_height_fraction`` of its start height, or tilted more than
    ``fall_tilt_deg`` once it has been upright (so lying at the start is not a fall). A motion
    that declares ``end: lying`` may lie down from its last keyframe but one on."""
    rollout, body = simulated.rollout, simulated.rollout.body
    if body is None:
        return []
    s0 = rollout.start_step
    height, tilt = body.height_m, body.tilt_deg
    start_height = float(height[s0])
    after = np.arange(len(height)) >= s0
    low = after & (height < thresholds.fall_height_fraction * start_height)
    upright = tilt <= thresholds.fall_tilt_deg
    been_upright = np.logical_or.accumulate(upright & after)
    tilted = after & been_upright & ~upright
    results = [*_ground_contacts(rollout, thresholds, s0, been_upright)]
    lying_from = simulated.lie_down_from_s
    if lying_from is not None:  # lying down at the end, as declared: low and on the floor
        lying = rollout.times_s >= lying_from
        low &= ~lying
        if simulated.end.pitch_deg:  # on its front or back: turned over too
            tilted &= ~lying
        results = [r for r in results if r.time_s < lying_from]
        results += _hard_landing(simulated, lying_from)
        results += _ends_turned_wrong(simulated)
    for mask, why in (
        (
            low,
            lambda k: (
                f"its height drops to {1000 * height[k]:.0f} mm "
                f"(from {1000 * start_height:.0f} mm at the start)"
            ),
        ),
        (tilted, lambda k: f"it tilts {tilt[k]:.0f}° from upright"),
    ):
        hits = np.flatnonzero(mask)
        if len(hits):
            k = int(hits[0])
            t = float(rollout.times_s[k])
            results.append(
                CheckResult(
                    CheckKind.FALL,
                    Severity.ERROR,
                    f"{body.name} falls at t={t:.2f} s: {why(k)}",
                    t,
                    bodies=(body.name,),
                    value=float(tilt[k]) if mask is tilted else float(height[k]),
                )
            )
    return results


def _hard_landing(simulated: SimulatedMotion, lying_from: float) -> list[CheckResult]:
    """A declared lie-down that comes down onto the ground faster than ``IMPACT_SPEED_M_S``:
    it falls, however it ends (one error, at the first such impact, naming what hits first)."""
    body = simulated.rollout.body
    assert body is not None  # impacts are measured on a free-floating robot only
    hard = [
        i for i in simulated.impacts if i.time_s >= lying_from and i.speed_m_s > IMPACT_SPEED_M_S
    ]
    if not hard:
        return []
    first = hard[0]
    others = sorted({i.link for i in hard} - {first.link})
    also = f" (then {', '.join(others)})" if others else ""
    return [
        CheckResult(
            CheckKind.FALL,
            Severity.ERROR,
            f"{body.name} falls while lying down at t={first.time_s:.2f} s: {first.link} hits the "
            f"{first.ground} first{also}, at {first.speed_m_s:.2f} m/s (a free fall of "
            f"{1000 * first.fall_height_m:.0f} mm; a controlled lie-down comes down slower than "
            f"{IMPACT_SPEED_M_S:g} m/s): lower it onto the floor with a keyframe on the way",
            first.time_s,
            bodies=(first.link, first.ground),
            value=first.speed_m_s,
        )
    ]


LYING_TURN_TOLERANCE_DEG = 45.0  # a body ending this far from the declared turn lies otherwise


def _ends_turned_wrong(simulated: SimulatedMotion) -> list[CheckResult]:
    """A motion declared to end face down (``lying_front``) or face up (``lying_back``) whose
    body ends otherwise (on its back, its side, or upright): its forward axis more than
    ``LYING_TURN_TOLERANCE_DEG`` from where the declared turn points it."""
    pitch = simulated.end.pitch_deg
    rollout, body = simulated.rollout, simulated.rollout.body
    if not pitch or body is None:
        return []
    w, x, y, z = rollout.qpos[-1, body.qpos_address + 3 : body.qpos_address + 7]
    forward = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)])
    # turned about its side-to-side axis by the pitch (±90°), its forward axis points down / up
    expected_z = -np.sin(np.radians(pitch))
    off = float(np.degrees(np.arccos(np.clip(forward[2] * expected_z, -1.0, 1.0))))
    if off <= LYING_TURN_TOLERANCE_DEG:
        return []
    how = "face down" if forward[2] < -0.5 else "face up" if forward[2] > 0.5 else "on its side"
    meant = "face down" if pitch > 0 else "face up"
    end_s = rollout.duration_s
    return [
        CheckResult(
            CheckKind.FALL,
            Severity.ERROR,
            f"{body.name} ends lying {how}, not {meant} as its end: {simulated.end.value} says "
            f"({off:.0f}° from it): it fell another way",
            end_s,
            bodies=(body.name,),
            value=off,
        )
    ]


def _ground_contacts(
    rollout: Rollout, thresholds: CheckThresholds, s0: int, been_upright: np.ndarray
):
    """Links other than feet on the ground after the start, once the robot has been upright
    (while it still lies, anything may rest on the floor)."""
    timeline = Timeline(rollout, thresholds)
    body = rollout.body
    assert body is not None  # check_fall made sure
    height, tilt = body.height_m, body.tilt_deg
    start_height = float(height[s0])
    for pair_index, pair in enumerate(rollout.contacts.pairs):
        if pair.kind != "ground":
            continue
        mask, _ = rollout.contacts.mask(pair_index, len(rollout.times_s))
        if mask[s0 : s0 + timeline.merge_steps + 1].any():
            continue  # it rested there at the start (lying)
        mask &= been_upright
        runs = timeline.episodes(mask)
        if not runs:
            continue
        k = runs[0][0]
        t = timeline.start(runs[0])
        yield CheckResult(
            CheckKind.FALL,
            Severity.ERROR,
            f"{pair.body_a} touches the {pair.body_b} at t={t:.2f} s: the robot collapses or "
            f"falls ({body.name} {1000 * start_height:.0f} -> "
            f"{1000 * float(height[k : runs[0][1]].min()):.0f} mm high, tilted up to "
            f"{float(tilt[k : runs[0][1]].max()):.1f}°)",
            t,
            timeline.duration(runs[0]),
            bodies=(pair.body_a, pair.body_b),
            value=float(tilt[k : runs[0][1]].max()),
        )


def check_stumble(simulated: SimulatedMotion, thresholds: CheckThresholds) -> list[CheckResult]:
    """A walker judged against its plan (``stance.py``), once upright and until a declared
    lie-down: its body lower than planned by ``stumble_drop_mm`` or tilted from the planned
    tilt by ``stumble_tilt_deg`` (both changes since the start), or a foot on the floor while
    the plan has it ``stumble_lift_mm`` up (the body came down onto a lifted leg)."""
    rollout, walk, body = simulated.rollout, simulated.walk, simulated.rollout.body
    stance = None if walk is None else walk.stance
    if stance is None or body is None or rollout.posture.lying:
        return []
    height, address = body.height_m, body.qpos_address
    timeline = Timeline(rollout, thresholds)
    judged = np.ones(len(rollout.times_s), dtype=bool)
    if simulated.lie_down_from_s is not None:
        judged &= rollout.times_s < simulated.lie_down_from_s
    drop_mm = 1000 * ((stance.height_m - stance.height_m[0]) - (height - height[0]))
    w, x, y, z = (rollout.qpos[:, address + 3 + i] for i in range(4))
    up = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)
    off = np.degrees(np.arccos(np.clip(np.sum(up * stance.up_base, axis=1), -1.0, 1.0)))
    tilt = off - off[0]
    results = []
    drop_limit, tilt_limit = thresholds.stumble_drop_mm, thresholds.stumble_tilt_deg
    for mask, what, values, limit, unit in (
        (drop_mm > drop_limit, "lower than its plan puts it", drop_mm, drop_limit, "mm"),
        (tilt > tilt_limit, "tilted more than planned", tilt, tilt_limit, "°"),
    ):
        runs = timeline.episodes(mask & judged)
        if runs:
            run = runs[0]
            worst = float(values[run[0] : run[1]].max())
            t = timeline.start(run)
            results.append(
                CheckResult(
                    CheckKind.FALL,
                    Severity.ERROR,
                    f"{body.name} stumbles at t={t:.2f} s: {worst:.1f} {unit} {what} (more "
                    f"than {limit:g} {unit}), for {timeline.duration(run):.2f} s",
                    t,
                    timeline.duration(run),
                    bodies=(body.name,),
                    value=worst,
                )
            )
    results += _lifted_feet_down(rollout, stance, timeline, thresholds, judged)
    return results


def _lifted_feet_down(rollout, stance, timeline, thresholds, judged):
    for pair_index, pair in enumerate(rollout.contacts.pairs):
        if pair.kind != "foot" or pair.body_a not in stance.foot_links:
            continue
        lift_mm = 1000 * stance.lift_m[:, stance.foot_links.index(pair.body_a)]
        touching, _ = rollout.contacts.mask(pair_index, len(rollout.times_s))
        runs = timeline.episodes(touching & judged & (lift_mm >= thresholds.stumble_lift_mm))
        if not runs:
            continue
        t = timeline.start(runs[0])
        yield CheckResult(
            CheckKind.FALL,
            Severity.ERROR,
            f"{pair.body_a} touches the {pair.body_b} at t={t:.2f} s while the plan has its foot "
            f"{float(lift_mm[runs[0][0] : runs[0][1]].max()):.0f} mm up: the body came down onto "
            f"a lifted leg",
            t,
            timeline.duration(runs[0]),
            bodies=(pair.body_a, pair.body_b),
            value=float(lift_mm[runs[0][0] : runs[0][1]].max()),
        )
