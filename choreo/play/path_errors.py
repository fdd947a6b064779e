"""How far the emulated servos strayed from the plan: the emulator's move log (servo IDs,
units) read back through the robot's joints (names, degrees).

The emulator knows nothing of robots; this module is where its wire-level record meets them.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from choreo.emulator.emulated_servo import StartedMove
from choreo.emulator.trace import executed_units
from choreo.plan.performance import Performance
from choreo.play.report import Outcome, StreamReport
from choreo.robot.types import Robot

SAMPLE_S = 0.002  # the path is compared every 2 ms


def path_errors_deg(
    moves: Iterable[StartedMove],
    robot: Robot,
    start_units: Sequence[float],
    start_time_s: float,
    times_s: np.ndarray,
    planned_deg: np.ndarray,
) -> tuple[float, ...]:
    """Per joint, the largest distance between where the emulated servo went and
    ``planned_deg`` (``(len(times_s), n_joints)`` degrees at ``start_time_s + times_s``)."""
    moves = list(moves)
    executed = np.stack(
        [
            executed_units(moves, joint.servo_id, start, start_time_s + times_s)
            for joint, start in zip(robot.joints, start_units)
        ],
        axis=-1,
    )  # (len(times_s), n_joints), like planned_deg
    errors = np.abs(robot.to_deg(executed) - planned_deg)
    return tuple(float(e) for e in np.max(errors, axis=0, initial=0.0))


def measured_path_errors(
    moves: Iterable[StartedMove],
    robot: Robot,
    performance: Performance,
    report: StreamReport,
    start_pose: Sequence[float],
) -> tuple[float, ...]:
    """Per joint, how far the emulated servos strayed from the smooth plan (every 2 ms) during
    a play that started with the servos at ``start_pose`` (degrees), over the part played:
    after a stop, the plan's remainder was never asked of the servos."""
    played_s = (
        report.planned_s
        if report.outcome is Outcome.COMPLETED
        else min(report.elapsed_s, report.planned_s)
    )
    times = np.arange(0.0, played_s, SAMPLE_S)
    start_units = [j.to_units(a) for j, a in zip(robot.joints, start_pose)]
    return path_errors_deg(
        moves, robot, start_units, report.start_time_s, times, performance.planned_deg(times)
    )
