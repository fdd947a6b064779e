"""The body's drag handle of a legged robot: the handle's move made into the ``body:`` pose a
motion file writes (mm and degrees, rounded as written) and the legs' angles that pose means,
solved as a ``body:`` keyframe is (``choreo.motion.spatial``): every foot kept where it stands.

A pose is a transform of the body from where it stood: ``p_before = R p_after + t``
(``BodyPose.rotation()`` is ``R``, its x, y, z are ``t``), as ``feet_under_body`` reads it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from choreo.motion.gait import BodyPose, feet_under_body
from choreo.robot.kinematics import Kinematics, SiteGoal, Solution
from choreo.studio.yaml_edit import number


@dataclass(frozen=True)
class BodyDrag:
    """A drag of the body's handle, from where it began: the handle then (world, m), the
    ``body:`` pose the robot was in, the feet's stance (the angles that planted them) and the
    angles the legs are solved from (as the keyframe before seeds a ``body:`` keyframe)."""

    handle_m: np.ndarray  # (3,)
    handle_rotation: np.ndarray  # (3, 3)
    start: BodyPose
    stance_deg: np.ndarray
    seed_deg: np.ndarray


def rotation_of(wxyz: npt.ArrayLike) -> np.ndarray:
    """The rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(wxyz, dtype=float) / np.linalg.norm(wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_of(rotation: np.ndarray, offset_mm: np.ndarray) -> BodyPose:
    """The ``BodyPose`` of a transform, rounded as a motion file gets it: ``rotation`` is
    ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = np.arcsin(np.clip(-rotation[2, 0], -1.0, 1.0))
    roll = np.arctan2(rotation[2, 1], rotation[2, 2])
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    x, y, z = (float(number(v)) for v in offset_mm)
    roll_deg, pitch_deg, yaw_deg = (float(number(np.degrees(a))) for a in (roll, pitch, yaw))
    return BodyPose(x, y, z, roll_deg, pitch_deg, yaw_deg)


def pose_after(drag: BodyDrag, handle_m: np.ndarray, handle_wxyz: npt.ArrayLike) -> BodyPose:
    """The body's pose once the handle moved from where the drag began to ``handle_m`` turned
    to ``handle_wxyz``: the drag's own move (in the body's frame) after the pose it began in."""
    turn = drag.handle_rotation.T @ rotation_of(handle_wxyz)
    shift_mm = drag.handle_rotation.T @ (np.asarray(handle_m, dtype=float) - drag.handle_m) * 1000
    start = drag.start
    rotation = start.rotation()
    offset = np.array([start.x_mm, start.y_mm, start.z_mm])
    return pose_of(rotation @ turn, rotation @ shift_mm + offset)


def solve_body(kinematics: Kinematics, feet: Sequence[str], drag: BodyDrag, pose: BodyPose):
    """The legs' angles with the body at ``pose`` and every foot where the stance put it."""
    stance_mm = np.array([kinematics.site_pose(foot, drag.stance_deg).position_mm for foot in feet])
    goals = [
        SiteGoal(foot, (float(x), float(y), float(z)))
        for foot, (x, y, z) in zip(feet, feet_under_body(stance_mm, pose))
    ]
    return kinematics.solve(goals, drag.seed_deg)


def farthest_foot(feet: Sequence[str], solution: Solution) -> tuple[str, float]:
    """The foot a pose out of reach misses most, and by how many mm."""
    worst = int(np.argmax(solution.position_error_mm))
    return feet[worst], float(solution.position_error_mm[worst])
