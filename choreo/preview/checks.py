"""Judging a rollout: what would go wrong on the robot, with joint/body names and times.

Each check turns a recorded signal into episodes (runs of steps where something is wrong, short
gaps merged) and reports one ``CheckResult`` per episode, at the time it starts.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from enum import Enum

import numpy as np

from choreo.bus.servo_models import rated_supply_problem
from choreo.core.arguments import NON_NEGATIVE, Range, check_number, check_type
from choreo.preview.impact import IMPACT_SPEED_M_S
from choreo.preview.props import PLACE_TOLERANCE_M
from choreo.preview.reach import REACH_ERROR_MM, REACH_WARNING_MM
from choreo.preview.sim import Rollout
from choreo.preview.simulated import SimulatedMotion, simulated_of
from choreo.preview.walk import LIFT_WARNING_FRACTION, TRAVEL_WARNING_FRACTION


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
            fraction = name in ("saturation_fraction", "near_miss_fraction")
            check_number(name, value, FRACTION if fraction else NON_NEGATIVE)


def run_checks(
    rollout: SimulatedMotion | Rollout, thresholds: CheckThresholds = CheckThresholds()
) -> list[CheckResult]:
    """Every problem found from the start (settled, before the approach), in time order:
    ``rollout`` is ``simulate_motion``'s, or a bare ``Rollout`` (``simulate``'s)."""
    simulated = simulated_of(rollout).since_start()
    check_type("thresholds", thresholds, CheckThresholds, "a CheckThresholds")
    recorded = simulated.rollout
    results = [
        *check_supply(recorded),
        *check_contacts(recorded, thresholds),
        *check_joint_limits(recorded, thresholds),
        *check_saturation(recorded, thresholds),
        *check_tracking(recorded, thresholds),
        *check_fall(simulated, thresholds),
        *check_stumble(simulated, thresholds),
        *check_props(simulated),
        *check_reach(simulated),
        *check_gaits(simulated),
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


def check_supply(rollout: Rollout) -> list[CheckResult]:
    """The supply the servos were simulated at (the robot file's, or an override) outside
    their model's rated range: an error, as ``choreo play`` refuses to play on it (and the
    servos' torque and speed, scaled with the supply, are a guess out there)."""
    joints_by_problem: dict[str, list[str]] = {}
    for joint, params in zip(rollout.robot.joints, rollout.actuators):
        problem = rated_supply_problem(joint.servo_model, params.supply_v)
        if problem is not None:
            joints_by_problem.setdefault(problem, []).append(joint.name)
    return [
        CheckResult(
            CheckKind.SUPPLY,
            Severity.ERROR,
            f"{', '.join(joints)}: {problem}: `choreo play` refuses such a supply, and the "
            f"servos' torque and speed here are scaled from their rated ones",
            rollout.start_s,
            joint=joints[0],
            value=rollout.actuators[rollout.robot.joint_names.index(joints[0])].supply_v,
        )
        for problem, joints in joints_by_problem.items()
    ]


def check_contacts(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    """Self-collisions, a fixed robot's links on the floor or a prop, and parent/child links
    that MuJoCo lets collide (a free-floating robot on the ground: ``check_fall``)."""
    timeline = _Timeline(rollout, thresholds)
    results = []
    for pair_index, pair in enumerate(rollout.contacts.pairs):
        if pair.kind in ("ground", "foot", "held"):
            continue
        mask, depth_by_step = rollout.contacts.mask(pair_index, len(rollout.times_s))
        for run in timeline.episodes(mask):
            depth_mm = 1000 * float(depth_by_step[run[0] : run[1]].max())
            when = f"at t={timeline.start(run):.2f} s for {timeline.duration(run):.2f} s"
            deep = f"(up to {depth_mm:.1f} mm deep)"
            if pair.kind == "self":
                kind = CheckKind.SELF_COLLISION
                message = f"self-collision: {pair.body_a} hits {pair.body_b} {when} {deep}"
            elif pair.kind == "neighbour":
                kind = CheckKind.NEIGHBOUR_CONTACT
                overlap = "overlap from the start" if run[0] == 0 else f"touch {when}"
                message = (
                    f"{pair.body_a} and {pair.body_b} {overlap} {deep}: they are parent and "
                    f"child, which the self-collision check leaves alone, but MuJoCo simulates "
                    f"this contact (one is fixed to the world) and pushes them apart; make "
                    f"their geoms clear each other in the MJCF, or exclude the pair "
                    f"(<contact><exclude body1=... body2=.../></contact>)"
                )
            else:
                kind = CheckKind.FLOOR_CONTACT
                message = f"{pair.body_a} touches the {pair.body_b} {when} {deep}"
            results.append(
                CheckResult(
                    kind,
                    Severity.ERROR,
                    message,
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
                            f"{joint.name} runs into its {side} limit {limit:g}° at "
                            f"t={start:.2f} s (reaching {worst:.1f}°) for {duration:.2f} s",
                            start,
                            duration,
                            joint=joint.name,
                            value=worst,
                        )
                    )
    return results


def check_saturation(rollout: Rollout, thresholds: CheckThresholds) -> list[CheckResult]:
    """Per joint, each stretch of torque near the servo's limit is one of: a stall (at the limit
    and nearly still for ``stall_after_s``: an error), can't keep up (at the limit but moving
    for that long: a warning with the lag), or a near miss (near the limit for
    ``near_miss_after_s``: a warning)."""
    timeline = _Timeline(rollout, thresholds)
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
    timeline = _Timeline(rollout, thresholds)
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
    timeline = _Timeline(rollout, thresholds)
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


def check_props(simulated: SimulatedMotion) -> list[CheckResult]:
    """Free props dropped after being lifted (error: whatever the motion meant to do with it,
    it did not mean to let it fall), knocked over (warning), or not ending at their
    ``place_at_m`` (error: the motion does not do what it says)."""
    results = []
    end_s = simulated.rollout.duration_s
    for outcome in simulated.props:
        name = outcome.name
        if outcome.dropped_at_s is not None:
            results.append(
                CheckResult(
                    CheckKind.PROP,
                    Severity.ERROR,
                    f"the {name} is dropped at t={outcome.dropped_at_s:.2f} s (lifted "
                    f"{1000 * outcome.lifted_m:.0f} mm, then falling faster than a controlled "
                    f"set-down): the grip does not hold it",
                    outcome.dropped_at_s,
                    bodies=(name,),
                    value=1000 * outcome.lifted_m,
                )
            )
        if outcome.knocked_over:
            results.append(
                CheckResult(
                    CheckKind.PROP,
                    Severity.WARNING,
                    f"the {name} is knocked over: it ends tilted {outcome.end_tilt_deg:.0f}° "
                    f"from how it stood",
                    end_s,
                    bodies=(name,),
                    value=outcome.end_tilt_deg,
                )
            )
        if outcome.placed is False:
            target = ", ".join(str(round(1000 * v)) for v in outcome.place_at_m or ())
            end = ", ".join(str(round(1000 * v)) for v in outcome.end_m)
            results.append(
                CheckResult(
                    CheckKind.PROP,
                    Severity.ERROR,
                    f"the {name} ends at [{end}] mm, {1000 * (outcome.place_error_m or 0):.0f} mm "
                    f"from its place target [{target}] mm (more than "
                    f"{1000 * PLACE_TOLERANCE_M:.0f} mm)",
                    end_s,
                    bodies=(name,),
                    value=1000 * (outcome.place_error_m or 0),
                )
            )
    return results


def check_reach(simulated: SimulatedMotion) -> list[CheckResult]:
    """A site more than ``REACH_WARNING_MM`` (warning) or ``REACH_ERROR_MM`` (error) from its
    ``sites:`` target when its keyframe is due; a small move in space that needed a large move
    in joints (warning)."""
    results = []
    for reach in simulated.site_reach:
        error = reach.error_mm
        if error <= REACH_WARNING_MM:
            continue
        severity = Severity.ERROR if error > REACH_ERROR_MM else Severity.WARNING
        limit = REACH_ERROR_MM if severity is Severity.ERROR else REACH_WARNING_MM
        target = ", ".join(f"{v:.0f}" for v in reach.target_mm)
        reached = ", ".join(f"{v:.0f}" for v in reach.reached_mm)
        results.append(
            CheckResult(
                CheckKind.REACH,
                severity,
                f"site {reach.site} is {error:.1f} mm from its target [{target}] mm at "
                f"t={reach.time_s:.2f} s (at [{reached}] mm, base frame; more than "
                f"{limit:g} mm): the arm sags or lags; aim higher, move slower, or lighten it",
                reach.time_s,
                bodies=(reach.site,),
                value=error,
            )
        )
    for jump in simulated.joint_jumps:
        results.append(
            CheckResult(
                CheckKind.JOINT_JUMP,
                Severity.WARNING,
                f"site {jump.site} moves only {jump.moved_mm:.0f} mm at t={jump.time_s:.2f} s "
                f"but {jump.joint} turns {jump.turned_deg:.0f}° to get there (inverse kinematics "
                f"found no nearer solution inside the joint limits: another branch of the arm, "
                f"or near a singularity); add a keyframe on the way, or move the target",
                jump.time_s,
                joint=jump.joint,
                bodies=(jump.site,),
                value=jump.turned_deg,
            )
        )
    return results


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
    timeline = _Timeline(rollout, thresholds)
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


def check_gaits(simulated: SimulatedMotion) -> list[CheckResult]:
    """A ``gait:`` block whose body travels or turns less than ``TRAVEL_WARNING_FRACTION`` of
    what it asked, or whose swinging feet rise less than ``LIFT_WARNING_FRACTION`` of the
    lift (they drag): warnings at the block's end."""
    results = []
    dues = () if simulated.walk is None else simulated.walk.gaits
    for outcome, due in zip(simulated.gaits, dues):
        short = []
        travel, turn, lift = outcome.travel_fraction, outcome.turn_fraction, outcome.lift_fraction
        if travel is not None and travel < TRAVEL_WARNING_FRACTION:
            asked = np.hypot(*outcome.asked_mm)
            short.append(f"travels {100 * travel:.0f} % of the {asked:.0f} mm")
        if turn is not None and turn < TRAVEL_WARNING_FRACTION:
            short.append(f"turns {100 * turn:.0f} % of the {outcome.asked_turn_deg:+.0f}°")
        if lift is not None and lift < LIFT_WARNING_FRACTION:
            short.append(
                f"its swinging feet rise only {100 * lift:.0f} % of the {outcome.lift_mm:g} mm "
                f"lift (they drag)"
            )
        if not short:
            continue
        results.append(
            CheckResult(
                CheckKind.GAIT,
                Severity.WARNING,
                f"the gait {' and '.join(short)} it asks for (the feet slip, or the servos give "
                f"way under the body: a longer period, a lower body or a higher lift help)",
                due.end_s,
                value=min(v for v in (travel, turn, lift) if v is not None),
            )
        )
    return results
