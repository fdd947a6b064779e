"""The servos' checks: saturation and stalls (at a prop the gripper squeezes, a warning naming the
angle that touches), a servo that cannot keep up, near misses, and tracking error."""

from __future__ import annotations

import numpy as np

from choreo.preview.findings import CheckKind, CheckResult, CheckThresholds, Severity, Timeline
from choreo.preview.rollout import Rollout


def check_saturation(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    """Per joint, each stretch of torque near the servo's limit is one of: a stall (at the limit
    and nearly still for ``stall_after_s``: an error), can't keep up (at the limit but moving
    for that long: a warning with the lag), or a near miss (near the limit for
    ``near_miss_after_s``: a warning)."""
    timeline = Timeline(rollout, thresholds)
    stall = rollout.stall_torque_nm
    share = np.abs(rollout.torque_nm) / stall
    velocity = _velocity_deg_s(rollout)
    # speed in the direction the servo pushes: being dragged backwards is not keeping up
    forward = velocity * np.sign(rollout.torque_nm)
    no_load = np.array([a.no_load_speed_deg_s for a in rollout.actuators])
    saturated = share >= thresholds.saturation_fraction
    still = forward < thresholds.stall_speed_fraction * no_load
    lag = np.abs(rollout.position_deg - rollout.command_deg)
    results = []
    for j in range(len(rollout.robot.joints)):
        near = min(thresholds.near_miss_fraction, thresholds.saturation_fraction)
        for run in timeline.episodes(share[:, j] >= near):
            span = slice(*run)
            result = (
                _stall(rollout, timeline, thresholds, j, run, saturated[span, j] & still[span, j])
                or _cant_keep_up(
                    rollout, timeline, thresholds, j, run, saturated[span, j], lag, velocity
                )
                or _near_miss(rollout, timeline, thresholds, j, run, share, lag, velocity)
            )
            if result is not None:
                results.append(result)
        if not any(r.joint == rollout.robot.joints[j].name for r in results):
            repeated = _repeated_near_miss(rollout, timeline, thresholds, j, share, lag, velocity)
            results += [repeated] if repeated is not None else []
    return results


def _repeated_near_miss(rollout, timeline, thresholds, j, share, lag, velocity):
    """Short pushes near the limit, each too short for a near miss, that add up to
    ``near_miss_after_s`` within ``near_miss_window_s``: the same strain, repeated (a fast
    step played again and again)."""
    near = share[:, j] >= min(thresholds.near_miss_fraction, thresholds.saturation_fraction)
    window = max(1, round(thresholds.near_miss_window_s / timeline.dt)) if timeline.dt else 1
    counts = np.concatenate(([0], np.cumsum(near)))
    within = counts[window:] - counts[:-window] if len(near) > window else counts[-1:]
    first = int(np.argmax(within))
    near_s = float(within[first]) * timeline.dt
    if near_s < thresholds.near_miss_after_s:
        return None
    span = slice(first, first + window)
    runs = timeline.episodes(near[span])
    start = float(timeline.times[first + runs[0][0]])
    peak = 100 * float(share[span, j].max())
    joint = rollout.robot.joints[j]
    return CheckResult(
        CheckKind.NEAR_MISS,
        Severity.WARNING,
        f"{joint.name} repeated near miss: its servo works at "
        f"{100 * thresholds.near_miss_fraction:.0f}-{peak:.0f} % of its stall torque {len(runs)} "
        f"times within {thresholds.near_miss_window_s:g} s from t={start:.2f} s, "
        f"{near_s:.2f} s in all (moving up to {float(np.abs(velocity[span, j]).max()):.0f}°/s of "
        f"its {rollout.actuators[j].no_load_speed_deg_s:.0f}°/s, lagging up to "
        f"{float(lag[span, j].max()):.1f}°): little margin for a heavier load or a faster move",
        start,
        thresholds.near_miss_window_s,
        joint=joint.name,
        value=peak,
    )


def _velocity_deg_s(rollout: Rollout) -> np.ndarray:
    if len(rollout.times_s) < 2:
        return np.zeros_like(rollout.position_deg)
    return np.gradient(rollout.position_deg, rollout.times_s, axis=0)


def _stall(rollout, timeline, thresholds, j, run, stalled) -> CheckResult | None:
    long_runs = [
        r for r in timeline.episodes(stalled) if timeline.duration(r) >= thresholds.stall_after_s
    ]
    if not long_runs:
        return None
    still_from = timeline.start((run[0] + long_runs[0][0], run[1]))
    stall_run = (run[0], run[0] + long_runs[-1][1])  # from reaching the limit to the end
    start, duration = timeline.start(stall_run), timeline.duration(stall_run)
    joint, torque = rollout.robot.joints[j], rollout.actuators[j].stall_torque_nm
    gripped = _gripping(rollout, j, stall_run)
    if gripped is not None:
        prop, touch_deg = gripped
        aims = rollout.setpoint_deg[stall_run[0] : stall_run[1], j]
        aim_deg = float(aims[np.argmax(np.abs(aims - touch_deg))]) + 0.0  # farthest past; no -0
        return CheckResult(
            CheckKind.SATURATION,
            Severity.WARNING,
            f"{joint.name} squeezes the {prop} at its full {torque:.2f} N·m torque for "
            f"{duration:.2f} s from t={start:.2f} s: it touches the {prop} at "
            f"{touch_deg:.1f}° and is aimed at {aim_deg:.1f}°; aim a few degrees past "
            f"{touch_deg:.1f}° to hold it with less (a servo at stall for long runs hot)",
            start,
            duration,
            joint=joint.name,
            bodies=(prop,),
            value=touch_deg,
        )
    moving_first = f", barely moving from t={still_from:.2f} s on" if still_from > start else ""
    return CheckResult(
        CheckKind.SATURATION,
        Severity.ERROR,
        f"{joint.name} stalls: its servo is at its {torque:.2f} N·m torque limit for "
        f"{duration:.2f} s from t={start:.2f} s{moving_first} (the load is too heavy, or the "
        f"joint is pushed against something){_touching(rollout, j, stall_run)}",
        start,
        duration,
        joint=joint.name,
        value=torque,
    )


def _cant_keep_up(rollout, timeline, thresholds, j, run, saturated, lag, velocity):
    at_limit_s = float(saturated.sum()) * timeline.dt
    if at_limit_s < thresholds.stall_after_s:
        return None
    span = slice(*run)
    start, duration = timeline.start(run), timeline.duration(run)
    worst_lag = float(lag[span, j].max())
    speed = float(np.abs(velocity[span, j]).max())
    joint, params = rollout.robot.joints[j], rollout.actuators[j]
    return CheckResult(
        CheckKind.CANT_KEEP_UP,
        Severity.WARNING,
        f"{joint.name} can't keep up: its servo is at its {params.stall_torque_nm:.2f} N·m "
        f"torque limit for {at_limit_s:.2f} s from t={start:.2f} s while moving (up to "
        f"{speed:.0f}°/s, no-load speed {params.no_load_speed_deg_s:.0f}°/s), lagging up to "
        f"{worst_lag:.1f}° behind its path{_touching(rollout, j, run)}",
        start,
        duration,
        joint=joint.name,
        value=worst_lag,
    )


def _near_miss(rollout, timeline, thresholds, j, run, share, lag, velocity):
    start, duration = timeline.start(run), timeline.duration(run)
    if duration < thresholds.near_miss_after_s:
        return None
    span = slice(*run)
    peak = 100 * float(share[span, j].max())
    joint = rollout.robot.joints[j]
    return CheckResult(
        CheckKind.NEAR_MISS,
        Severity.WARNING,
        f"{joint.name} near miss: its servo works at {100 * thresholds.near_miss_fraction:.0f}-"
        f"{peak:.0f} % of its stall torque for {duration:.2f} s from t={start:.2f} s "
        f"(moving up to {float(np.abs(velocity[span, j]).max()):.0f}°/s of its "
        f"{rollout.actuators[j].no_load_speed_deg_s:.0f}°/s, lagging up to "
        f"{float(lag[span, j].max()):.1f}°): little margin for a heavier load or a faster "
        f"move{_touching(rollout, j, run)}",
        start,
        duration,
        joint=joint.name,
        value=peak,
    )


def _touching(rollout: Rollout, j: int, run: tuple[int, int]) -> str:
    """ ", while A touches B" for a contact of the joint's link during ``run`` (the real cause
    of a servo straining), or ""."""
    if not rollout.joint_links:
        return ""
    link, contacts = rollout.joint_links[j], rollout.contacts
    during = (contacts.step >= run[0]) & (contacts.step < run[1])
    for pair_index in np.unique(contacts.pair[during]):
        pair = contacts.pairs[pair_index]
        if pair.kind != "foot" and link in (pair.body_a, pair.body_b):
            return f", pushed by a contact: {pair.body_a} touches {pair.body_b}"
    return ""


def _gripping(rollout: Rollout, j: int, run: tuple[int, int]) -> tuple[str, float] | None:
    """The free prop the joint's link grips through ``run`` (touching it, with another link
    on it too: held between them, as in a gripper's fingers), and the joint's angle when the
    link began to touch it; None if it grips none."""
    if not rollout.joint_links:
        return None
    link, contacts, steps = rollout.joint_links[j], rollout.contacts, len(rollout.times_s)
    free = {name for name, _ in rollout.prop_qpos_addresses}
    on_prop: dict[str, dict[str, np.ndarray]] = {}  # prop -> robot link -> touching per step
    for pair_index, pair in enumerate(contacts.pairs):
        if pair.kind == "held":
            touching, _ = contacts.mask(pair_index, steps)
            prop, robot_link = (
                (pair.body_a, pair.body_b) if pair.body_a in free else (pair.body_b, pair.body_a)
            )
            on_prop.setdefault(prop, {})[robot_link] = touching
    for prop, links in on_prop.items():
        mine = links.get(link)
        if mine is None or mine[run[0] : run[1]].mean() < 0.9:
            continue
        if not any(
            other[run[0] : run[1]].mean() >= 0.9 for name, other in links.items() if name != link
        ):
            continue  # pushed, not held between two links
        began = 0 if mine[0] else run[0] - int(np.argmin(mine[run[0] :: -1])) + 1
        return prop, float(rollout.position_deg[min(began, run[0]), j])
    return None


def check_tracking(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    """A joint far off its commanded path: an error when it lasts, a warning when short or
    when the joint holds a free prop that stops it (a gripper closed on what it carries)."""
    timeline = Timeline(rollout, thresholds)
    error = np.abs(rollout.position_deg - rollout.command_deg)
    limit = thresholds.max_tracking_error_deg
    results = []
    for j, joint in enumerate(rollout.robot.joints):
        for run in timeline.episodes(error[:, j] > limit):
            start, duration = timeline.start(run), timeline.duration(run)
            worst = float(error[run[0] : run[1], j].max())
            gripped = _gripping(rollout, j, run)
            lasting = duration >= thresholds.tracking_error_after_s and gripped is None
            held = f", held open by the {gripped[0]} it grips" if gripped else ""
            results.append(
                CheckResult(
                    CheckKind.TRACKING_ERROR,
                    Severity.ERROR if lasting else Severity.WARNING,
                    f"{joint.name} is {worst:.1f}° off its commanded path (more than {limit:g}°) "
                    f"from t={start:.2f} s for {duration:.2f} s{held}",
                    start,
                    duration,
                    joint=joint.name,
                    value=worst,
                )
            )
    return results
