"""The ``--report`` JSON: every check result, and per joint the worst tracking error and torque."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .checks import CheckResult, Severity
from .sim import Rollout
from .travel import body_travel


@dataclass(frozen=True)
class JointSummary:
    joint: str
    max_tracking_error_deg: float
    max_tracking_error_time_s: float
    peak_torque_nm: float
    peak_torque_time_s: float
    stall_torque_nm: float


def joint_summaries(rollout: Rollout) -> list[JointSummary]:
    error = np.abs(rollout.position_deg - rollout.command_deg)
    torque = np.abs(rollout.torque_nm)
    summaries = []
    for j, joint in enumerate(rollout.robot.joints):
        worst_error, peak = int(np.argmax(error[:, j])), int(np.argmax(torque[:, j]))
        summaries.append(
            JointSummary(
                joint=joint.name,
                max_tracking_error_deg=round(float(error[worst_error, j]), 3),
                max_tracking_error_time_s=round(float(rollout.times_s[worst_error]), 4),
                peak_torque_nm=round(float(torque[peak, j]), 4),
                peak_torque_time_s=round(float(rollout.times_s[peak]), 4),
                stall_torque_nm=round(rollout.actuators[j].stall_torque_nm, 4),
            )
        )
    return summaries


def preview_report(rollout: Rollout, results: list[CheckResult], motion: str = "") -> dict:
    errors = sum(r.severity is Severity.ERROR for r in results)
    return {
        "robot": rollout.robot.name,
        "motion": motion,
        "duration_s": round(rollout.duration_s, 4),
        "commands_end_s": round(rollout.commands_end_s, 4),
        "ok": errors == 0,
        "errors": errors,
        "warnings": len(results) - errors,
        "checks": [r.to_dict() for r in results],
        "joints": [asdict(s) for s in joint_summaries(rollout)],
        "body_travel": travel.to_dict() if (travel := body_travel(rollout)) else None,
    }
