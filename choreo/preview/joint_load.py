"""One joint's load with the rest of the robot held still: what identification fits a servo
against.

The robot's own links are the load: over the joint's range, with every other joint held at a
pose (and a free-floating robot's body held where it stands, as on a stand), MuJoCo gives the
joint's inertia (the servo's armature included) and the torque gravity puts on it. ``choreo
identify`` simulates its test moves on this one degree of freedom, thousands of times, instead of
the whole robot.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.preview.actuator import actuator_params
from choreo.preview.model import apply_servo_models, index_joints, load_model
from choreo.preview.start import start_state
from choreo.robot.types import Robot

GRID_STEP_DEG = 1.0


@dataclass(frozen=True)
class JointLoad:
    """Joint ``joint``'s load over ``angles_deg`` (its real angle, robot frame): inertia about
    its axis and the torque gravity puts on it (positive: towards larger angles)."""

    joint: str
    angles_deg: np.ndarray
    inertia_kg_m2: np.ndarray
    gravity_nm: np.ndarray
    timestep_s: float  # the model's physics step

    def gravity_at(self, angle_rad: np.ndarray) -> np.ndarray:
        return np.interp(np.degrees(angle_rad), self.angles_deg, self.gravity_nm)

    def inertia_at(self, angle_rad: np.ndarray) -> np.ndarray:
        return np.interp(np.degrees(angle_rad), self.angles_deg, self.inertia_kg_m2)


def joint_load(
    robot: Robot,
    joint: str,
    pose_deg: Sequence[float],
    overrides: Mapping[str, Mapping[str, float]] | None = None,
) -> JointLoad:
    """``joint``'s load over its limits, the other joints at ``pose_deg`` (robot order), the
    servos' armature from their figures (``overrides`` as for ``actuator_params``)."""
    model = load_model(robot)
    index = index_joints(model, robot)
    apply_servo_models(model, index, actuator_params(robot, overrides), robot)
    j = robot.joint_names.index(joint)
    limits = robot.joints[j].limits
    angles = np.arange(limits.min_deg, limits.max_deg + GRID_STEP_DEG / 2, GRID_STEP_DEG)
    data = start_state(model, index, np.asarray(pose_deg, dtype=float))
    dof, address = int(index.dof[j]), int(index.qpos[j])
    inertia, gravity = np.empty(len(angles)), np.empty(len(angles))
    # M·e_dof, read at dof: the joint's own inertia. mj_mulM takes the same arguments in every
    # MuJoCo choreo allows, where mj_fullM's changed in 4.0 (data in place of its qM).
    unit, column = np.zeros(model.nv), np.zeros(model.nv)
    unit[dof] = 1.0
    for k, angle in enumerate(angles):
        data.qpos[address] = np.radians(angle)
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        mujoco.mj_mulM(model, data, column, unit)
        inertia[k] = column[dof]
        gravity[k] = -data.qfrc_bias[dof]  # at rest the bias is gravity alone
    return JointLoad(joint, angles, inertia, gravity, float(model.opt.timestep))
