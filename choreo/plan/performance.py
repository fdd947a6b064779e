"""A performance: what the player will send, the slow approach from where the servos are into
the motion's first pose, then the motion, as one tick list. Planning, not playing: the preview
starts from the same performance the player plays."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from choreo.bus.protocol import SPECS, Command
from choreo.core.arguments import check_type
from choreo.errors import OptionError
from choreo.plan.approach import slow_approach
from choreo.plan.pipeline import CompiledMotion
from choreo.plan.planner import pose_array
from choreo.plan.ticks import Tick, TickPlan
from choreo.plan.trajectory import Trajectory
from choreo.robot.types import Robot


@dataclass(frozen=True)
class Performance:
    """What will be played: the approach from the measured pose, then the motion, as one tick
    list."""

    approach: TickPlan
    motion: TickPlan
    trajectory: Trajectory  # of the motion, starting at ``approach_s``
    approach_trajectory: Trajectory

    @property
    def approach_s(self) -> float:
        return self.approach.duration_ms / 1000

    @property
    def ticks(self) -> tuple[Tick, ...]:
        offset = self.approach.duration_ms
        return self.approach.ticks + tuple(
            replace(t, start_ms=t.start_ms + offset) for t in self.motion.ticks
        )

    def planned_deg(self, times_s: np.ndarray) -> np.ndarray:
        """The smooth plan (approach, then motion) at ``times_s`` from the first START."""
        times_s = np.asarray(times_s, dtype=float)
        in_approach = times_s < self.approach_s
        out = np.empty((len(times_s), self.trajectory.n_joints))
        out[in_approach] = self.approach_trajectory.positions(times_s[in_approach])
        out[~in_approach] = self.trajectory.positions(times_s[~in_approach] - self.approach_s)
        return out


# what a servo reports where it is (POS_READ): a start pose beyond it is no servo's
_REPORTED = SPECS[Command.POS_READ].reply[0]  # type: ignore[index]  # POS_READ is answered


def servo_pose(robot: Robot, start_pose_deg: object) -> list[float]:
    """``start_pose_deg`` if each angle is one its servo could report (``OptionError`` if not)."""
    angles = pose_array(robot, start_pose_deg, "start_pose_deg")
    for joint, angle in zip(robot.joints, angles):
        low, high = sorted((joint.to_deg(_REPORTED.lo), joint.to_deg(_REPORTED.hi)))
        if not low <= angle <= high:
            raise OptionError(
                "start_pose_deg",
                f"puts {joint.name} at {angle:g}°, where no servo can be ({_REPORTED.lo}.."
                f"{_REPORTED.hi} units): pass where the servos are (what preflight measures)",
            )
    return angles.tolist()


def prepare(compiled: CompiledMotion, start_pose_deg: Sequence[float]) -> Performance:
    """Add the slow approach (``choreo.plan.approach``) from ``start_pose_deg`` (where the servos
    are) into the first pose."""
    check_type("compiled", compiled, CompiledMotion, "a CompiledMotion (from compile_motion)")
    robot = compiled.robot
    start_pose_deg = servo_pose(robot, start_pose_deg)
    first_pose = compiled.trajectory.at(0.0)[0]
    approach = slow_approach(robot, start_pose_deg, first_pose, compiled.tolerance_deg)
    return Performance(approach.tick_plan, compiled.ticks, compiled.trajectory, approach.trajectory)
