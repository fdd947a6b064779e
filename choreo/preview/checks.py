"""Judging a rollout: what would go wrong on the robot, with joint/body names and times.

Each check turns a recorded signal into episodes (runs of steps where something is wrong, short
gaps merged) and reports one ``CheckResult`` per episode, at the time it starts.
"""

from __future__ import annotations

import numpy as np

from choreo.bus.servo_models import rated_supply_problem
from choreo.core.arguments import check_type
from choreo.preview.body_checks import check_fall, check_stumble
from choreo.preview.findings import (
    CheckKind,
    CheckResult,
    CheckThresholds,
    Severity,
    Timeline,
)
from choreo.preview.props import PLACE_TOLERANCE_M
from choreo.preview.reach import REACH_ERROR_MM, REACH_WARNING_MM
from choreo.preview.rollout import Rollout
from choreo.preview.servo_checks import check_saturation, check_tracking
from choreo.preview.simulated import SimulatedMotion, simulated_of
from choreo.preview.walk import LIFT_WARNING_FRACTION, TRAVEL_WARNING_FRACTION

DEFAULT_THRESHOLDS = CheckThresholds()  # frozen: one value serves every call


def run_checks(
    rollout: SimulatedMotion | Rollout, thresholds: CheckThresholds = DEFAULT_THRESHOLDS
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
    timeline = Timeline(rollout, thresholds)
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
    timeline = Timeline(rollout, thresholds)
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
