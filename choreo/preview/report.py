"""The ``--report`` JSON: how the simulation started and what it assumed, every check result,
and per joint the worst tracking error and torque (peak as % of stall, time near the limit)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from choreo.core.arguments import check_text, check_type, shown
from choreo.errors import OptionError, Worded, joined
from choreo.preview.actuator import FigureSource, figure_sources
from choreo.preview.findings import CheckResult, CheckThresholds, Severity
from choreo.preview.rollout import Rollout
from choreo.preview.simulated import SimulatedMotion, simulated_of


@dataclass(frozen=True)
class JointSummary:
    joint: str
    max_tracking_error_deg: float
    max_tracking_error_time_s: float
    peak_torque_nm: float
    peak_torque_time_s: float
    stall_torque_nm: float
    peak_torque_pct: float  # of the stall torque
    near_limit_s: float  # time spent at or above the near-miss share of the stall torque
    supply_v: float
    deadband_deg: float
    backlash_deg: float


def joint_summaries(
    rollout: Rollout, near_miss_fraction: float = CheckThresholds().near_miss_fraction
) -> list[JointSummary]:
    error = np.abs(rollout.position_deg - rollout.command_deg)
    torque = np.abs(rollout.torque_nm)
    dt = float(rollout.times_s[1] - rollout.times_s[0]) if len(rollout.times_s) > 1 else 0.0
    summaries = []
    for j, joint in enumerate(rollout.robot.joints):
        worst_error, peak = int(np.argmax(error[:, j])), int(np.argmax(torque[:, j]))
        params = rollout.actuators[j]
        share = torque[:, j] / params.stall_torque_nm
        summaries.append(
            JointSummary(
                joint=joint.name,
                max_tracking_error_deg=round(float(error[worst_error, j]), 3),
                max_tracking_error_time_s=round(float(rollout.times_s[worst_error]), 4),
                peak_torque_nm=round(float(torque[peak, j]), 4),
                peak_torque_time_s=round(float(rollout.times_s[peak]), 4),
                stall_torque_nm=round(params.stall_torque_nm, 4),
                peak_torque_pct=round(100 * float(share[peak]), 1),
                near_limit_s=round(float(np.sum(share >= near_miss_fraction)) * dt, 4),
                supply_v=params.supply_v,
                deadband_deg=params.deadband_deg,
                backlash_deg=params.backlash_deg,
            )
        )
    return summaries


def start_lines(rollout: Rollout) -> list[str]:
    """How the simulation started and what it assumed, one line each, for the CLI (the servo
    model's line names the argument that changes its assumption: ``worded``)."""
    lines = []
    settling = rollout.settling
    if settling is not None:
        still = "still" if settling.still else "still moving"
        if rollout.body is not None:
            lines.append(
                f"start: {rollout.posture.value} on the floor; settled for "
                f"{settling.duration_s:.2f} s until {still}: {rollout.body.name} dropped "
                f"{1000 * settling.drop_m:.1f} mm and tilted {settling.tilt_deg:.1f}°"
            )
        else:
            lines.append(f"start: held the start pose {settling.duration_s:.2f} s until {still}")
    if rollout.approach_start_s < 0:
        lines.append(
            f"approach: {-rollout.approach_start_s:.2f} s into the first keyframe "
            f"(from t={rollout.approach_start_s:.2f} s), as the player plays it"
        )
    lines.append(f"servo figures: {figures_text(figure_sources(rollout.robot))}")
    lines.append(joined("", ("servo model: ", assumptions_text(rollout))))
    return lines


FIGURE_WORDS = {
    "stall_torque_nm": "stall torque",
    "no_load_speed_deg_s": "no-load speed",
    "kp_nm_rad": "gain",
    "damping_nm_s_rad": "damping",
    "armature_kg_m2": "armature",
    "supply_v": "supply",
    "deadband_deg": "dead band",
    "backlash_deg": "backlash",
    "friction_nm": "friction",
    "response_delay_s": "response delay",
    "offset_deg": "offset",
}


def figures_text(sources: tuple[FigureSource, ...]) -> str:
    """Which servo figures are measured on the robot (and when) and which are still assumed,
    by source: the figures of a source together, the joints named where not all share it."""
    everyone = {joint for source in sources for joint in source.joints}
    measured: dict[str, list[str]] = {}
    assumed: dict[str, list[str]] = {}
    for source in sources:
        word = FIGURE_WORDS[source.figure]
        if set(source.joints) != everyone:
            word += f" ({', '.join(source.joints)})"
        if source.measured:
            measured.setdefault(f"measured {source.measured_on} ({source.source})", []).append(word)
        else:
            assumed.setdefault(source.source, []).append(word)
    measured_text, assumed_text = (
        "; ".join(f"{', '.join(words)}: {where}" for where, words in by.items())
        for by in (measured, assumed)
    )
    if not measured:
        return f"all assumed (not measured on this robot); {assumed_text}"
    return measured_text + (f"; still assumed: {assumed_text}" if assumed else "")


def busiest_line(rollout: Rollout, near_miss_fraction: float) -> str:
    """The servo working hardest, for the CLI (every joint's figures are in the report)."""
    summaries = joint_summaries(rollout.since_start(), near_miss_fraction)
    worst = max(summaries, key=lambda s: (s.peak_torque_pct, s.near_limit_s))
    line = (
        f"hardest-working servo: {worst.joint} at up to {worst.peak_torque_pct:.0f} % of its "
        "stall torque"
    )
    if worst.near_limit_s > 0:  # the time near the limit says nothing when it never got there
        line += f" ({worst.near_limit_s:.2f} s at {100 * near_miss_fraction:.0f} % or more)"
    return line


def reach_line(simulated: SimulatedMotion) -> str | None:
    """The worst ``sites:`` target, for the CLI (each one's figures are in the report)."""
    if not simulated.site_reach:
        return None
    worst = max(simulated.site_reach, key=lambda r: r.error_mm)
    return (
        f"sites: {len(simulated.site_reach)} target(s) reached within {worst.error_mm:.1f} mm "
        f"(worst: {worst.site} at t={worst.time_s:.2f} s, {worst.where})"
    )


def assumptions_text(rollout: Rollout) -> str:
    """The servo model's assumptions, each value once with the joints that differ named, and
    where moves start (naming ``SimSettings.move_start``)."""
    parts = []
    for field, unit in (
        ("supply_v", " V"),
        ("deadband_deg", "° dead band"),
        ("backlash_deg", "° backlash"),
    ):
        values = [getattr(a, field) for a in rollout.actuators]
        common = max(set(values), key=values.count)
        others = [
            f"{joint.name} {value:g}"
            for joint, value in zip(rollout.robot.joints, values)
            if value != common
        ]
        text = f"{common:g}{unit}"
        if field == "supply_v":
            rated = sorted({a.rated_supply_v for a in rollout.actuators})
            text = f"supply {text} (rated {', '.join(f'{r:g}' for r in rated)} V)"
        parts.append(text + (f" ({', '.join(others)})" if others else ""))
    parts.append(
        Worded(f"moves start from the {rollout.move_start.value} ({{move_start}})", ("move_start",))
    )
    return joined(", ", parts)


def preview_report(
    rollout: SimulatedMotion | Rollout,
    results: list[CheckResult],
    motion: str = "",
    thresholds: CheckThresholds | None = None,
) -> dict:
    """What ``choreo preview --report`` writes: the checks' ``results`` on ``rollout``
    (``simulate_motion``'s, of the motion file ``motion``) and the figures they were judged
    by."""
    simulated = simulated_of(rollout)
    recorded = simulated.rollout
    if not isinstance(results, list) or not all(isinstance(r, CheckResult) for r in results):
        raise OptionError(
            "results", f"must be a list of CheckResult (from run_checks), got {shown(results)}"
        )
    check_text("motion", motion)
    if thresholds is not None:
        check_type("thresholds", thresholds, CheckThresholds, "a CheckThresholds, or None")
    thresholds = thresholds or CheckThresholds()
    errors = sum(r.severity is Severity.ERROR for r in results)
    settling = recorded.settling
    return {
        "robot": recorded.robot.name,
        "motion": motion,
        "start_s": round(recorded.start_s, 4),
        "approach_start_s": round(recorded.approach_start_s, 4),
        "duration_s": round(recorded.duration_s, 4),
        "commands_end_s": round(recorded.commands_end_s, 4),
        "start": {
            "posture": recorded.posture.value,
            "settle_s": round(settling.duration_s, 4) if settling else 0.0,
            "still": settling.still if settling else True,
            "drop_mm": round(1000 * settling.drop_m, 2) if settling else 0.0,
            "tilt_deg": round(settling.tilt_deg, 2) if settling else 0.0,
            # what may touch the ground (a free-floating robot)
            "feet": list(recorded.body.feet) if recorded.body else [],
        },
        "assumptions": {
            "move_start": recorded.move_start.value,
            "summary": assumptions_text(recorded),
            # where each servo figure comes from; "measured": false until identified
            "figures": [source.to_dict() for source in figure_sources(recorded.robot)],
        },
        "ok": errors == 0,
        "errors": errors,
        "warnings": len(results) - errors,
        "checks": [r.to_dict() for r in results],
        # judged like the checks: from the start, after settling
        "joints": [
            asdict(s)
            for s in joint_summaries(recorded.since_start(), thresholds.near_miss_fraction)
        ],
        "body_travel": simulated.travel.to_dict() if simulated.travel else None,
        "props": [outcome.to_dict() for outcome in simulated.props],
        "site_reach": [reach.to_dict() for reach in simulated.site_reach],
        "gaits": [outcome.to_dict() for outcome in simulated.gaits],
        # links coming down onto the ground during a declared lie-down (``end: lying``)
        "impacts": [impact.to_dict() for impact in simulated.impacts],
    }
