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
from choreo.preview.model import JointIndex, apply_servo_models, index_joints, load_model
from choreo.preview.start import start_state
from choreo.robot.types import Robot

GRID_STEP_DEG = 1.0
MAX_NEIGHBOURS = 2  # each one read costs the joint's own reads a quarter of the bus
# a neighbour coupled more weakly than this (its coupling inertia over the geometric mean of both
# inertias: 0 for crossed axes) barely pushes on the joint: not worth its reads. arm6's elbow
# and shoulder are 0.56, elbow and wrist_pitch 0.21, tonypi's knee and hip 0.23; its knee and
# ankle, 0.05, are left out
MIN_COUPLING = 0.1
SLOPE_STEP_RAD = np.radians(0.5)  # the gravity slope's finite difference


@dataclass(frozen=True)
class Coupling:
    """How neighbour ``joint`` moving pushes on the loaded joint, over the loaded joint's grid:
    the mass matrix between them (its acceleration times this is a torque against the joint)
    and the change of the gravity torque on the joint per radian of the neighbour."""

    joint: str
    inertia_kg_m2: np.ndarray
    gravity_nm_rad: np.ndarray


@dataclass(frozen=True)
class SoftFriction:
    """How MuJoCo holds the joint by its dry friction (``frictionloss``): not dead still but
    as a soft constraint. Below its limit the friction torque is
    ``-(torque + inertia * damping_per_s * velocity) / (1 + inertia * softness)`` (the torque
    the joint's damping left, its inertia about its axis): it aims to stop the joint at
    ``damping_per_s`` and lets ``inertia * softness / (1 + inertia * softness)`` of the torque
    through (a tenth to a seventh on arm6), so a joint held by friction creeps on."""

    softness: float  # the constraint's regulariser: (1 - d) / d times the dof's inverse weight
    damping_per_s: float  # 2 / (dmax * timeconst): the stop it aims for

    @classmethod
    def of(cls, model: mujoco.MjModel, dof: int) -> SoftFriction:
        """As MuJoCo's solver has it for ``dof`` (its solref and solimp; the impedance of a
        friction constraint, which nothing violates, is solimp's dmin; the inverse weight is
        the one MuJoCo took at qpos0, as it does, whatever the pose)."""
        timeconst = max(float(model.dof_solref[dof, 0]), 2 * float(model.opt.timestep))
        d_min, d_max = (float(x) for x in model.dof_solimp[dof, :2])
        softness = (1 - d_min) / d_min * float(model.dof_invweight0[dof])
        return cls(softness, 2 / (d_max * timeconst))


@dataclass(frozen=True)
class JointLoad:
    """Joint ``joint``'s load over ``angles_deg`` (its real angle, robot frame): inertia about
    its axis and the torque gravity puts on it (positive: towards larger angles)."""

    joint: str
    angles_deg: np.ndarray
    inertia_kg_m2: np.ndarray
    gravity_nm: np.ndarray
    timestep_s: float  # the model's physics step
    friction: SoftFriction  # how MuJoCo's dry friction on it holds
    # its neighbours in the chain that push on it when they yield (at most MAX_NEIGHBOURS)
    neighbours: tuple[Coupling, ...] = ()

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
    servos' armature from their figures (``overrides`` as for ``actuator_params``), with how its
    chain neighbours push on it."""
    model = load_model(robot)
    index = index_joints(model, robot)
    apply_servo_models(model, index, actuator_params(robot, overrides), robot)
    j = robot.joint_names.index(joint)
    limits = robot.joints[j].limits
    angles = np.arange(limits.min_deg, limits.max_deg + GRID_STEP_DEG / 2, GRID_STEP_DEG)
    data = start_state(model, index, np.asarray(pose_deg, dtype=float))
    dof, address = int(index.dof[j]), int(index.qpos[j])
    near = _chain_neighbours(model, index, j)
    inertia, gravity = np.empty(len(angles)), np.empty(len(angles))
    coupling, slope = np.empty((len(near), len(angles))), np.empty((len(near), len(angles)))
    # M·e_dof: the joint's own inertia at dof, its coupling with each neighbour at theirs.
    # mj_mulM takes the same arguments in every MuJoCo choreo allows, where mj_fullM's changed
    # in 4.0 (data in place of its qM).
    unit, column = np.zeros(model.nv), np.zeros(model.nv)
    unit[dof] = 1.0
    for k, angle in enumerate(angles):
        data.qpos[address] = np.radians(angle)
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        mujoco.mj_mulM(model, data, column, unit)
        inertia[k] = column[dof]
        gravity[k] = -data.qfrc_bias[dof]  # at rest the bias is gravity alone
        for n, other in enumerate(near):
            coupling[n, k] = column[index.dof[other]]
            slope[n, k] = _gravity_slope(model, data, dof, int(index.qpos[other]))
    data.qpos[address] = np.radians(pose_deg[j])  # the neighbours' own inertia, at the pose
    kept = _strongly_coupled(near, coupling, inertia, model, data, index)
    neighbours = tuple(Coupling(robot.joint_names[near[n]], coupling[n], slope[n]) for n in kept)
    friction = SoftFriction.of(model, dof)
    return JointLoad(
        joint, angles, inertia, gravity, float(model.opt.timestep), friction, neighbours
    )


def _chain_neighbours(model: mujoco.MjModel, index: JointIndex, j: int) -> list[int]:
    """The robot joints (robot order) next to joint ``j`` in the kinematic tree: the nearest
    one it hangs from, and those whose nearest one up the tree is ``j``."""
    robot_of_dof = {int(d): n for n, d in enumerate(index.dof)}

    def parent(n: int) -> int | None:
        dof = int(model.dof_parentid[index.dof[n]])
        while dof >= 0 and dof not in robot_of_dof:
            dof = int(model.dof_parentid[dof])
        return robot_of_dof.get(dof)

    up = parent(j)
    return ([] if up is None else [up]) + [n for n in robot_of_dof.values() if parent(n) == j]


def _gravity_slope(model: mujoco.MjModel, data: mujoco.MjData, dof: int, address: int) -> float:
    """d(gravity torque on ``dof``)/d(the angle at qpos ``address``), at rest, N·m/rad."""
    torque = []
    held = float(data.qpos[address])
    for shift in (SLOPE_STEP_RAD, -SLOPE_STEP_RAD):
        data.qpos[address] = held + shift
        mujoco.mj_forward(model, data)
        torque.append(-data.qfrc_bias[dof])
    data.qpos[address] = held
    return float((torque[0] - torque[1]) / (2 * SLOPE_STEP_RAD))


def _strongly_coupled(
    near: list[int],
    coupling: np.ndarray,
    inertia: np.ndarray,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index: JointIndex,
) -> list[int]:
    """Of ``near`` (rows of ``coupling``), the MAX_NEIGHBOURS most strongly coupled to the
    joint, weaker than MIN_COUPLING left out."""
    own = np.empty(len(near))
    diagonal = np.zeros(model.nv)
    mujoco.mj_forward(model, data)
    for n, other in enumerate(near):  # each neighbour's own inertia
        unit = np.zeros(model.nv)
        unit[index.dof[other]] = 1.0
        mujoco.mj_mulM(model, data, diagonal, unit)
        own[n] = diagonal[index.dof[other]]
    strength = np.abs(coupling).max(axis=1, initial=0.0) / np.sqrt(own * inertia.max())
    ranked = sorted(range(len(near)), key=lambda n: -strength[n])
    return sorted(n for n in ranked[:MAX_NEIGHBOURS] if strength[n] >= MIN_COUPLING)
