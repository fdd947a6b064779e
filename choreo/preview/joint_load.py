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
from dataclasses import dataclass, field

import mujoco
import numpy as np

from choreo.preview.actuator import ActuatorParams, actuator_params
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
    and the change of the gravity torque on the joint per radian of the neighbour; the gravity
    torque on the neighbour where it holds, over the same grid; and the servo that holds it."""

    joint: str
    inertia_kg_m2: np.ndarray
    gravity_nm_rad: np.ndarray
    held_gravity_nm: np.ndarray
    servo: ActuatorParams


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
    # its neighbours in the chain that push on it when they yield (at most MAX_NEIGHBOURS);
    # among them and those they carry (``carried``), over the grid (grid, n, n): their mass
    # matrix, and the change of the gravity torque on each (row) per radian of each (column)
    neighbours: tuple[Coupling, ...] = ()
    neighbour_inertia_kg_m2: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0)))
    neighbour_gravity_nm_rad: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0)))
    # the neighbours' own neighbours that move with them (not read: the matrices above take
    # them after the neighbours), e.g. the shoulder's elbow carrying the wrist_pitch
    carried: tuple[Coupling, ...] = ()

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
    params = actuator_params(robot, overrides)
    apply_servo_models(model, index, params, robot)
    j = robot.joint_names.index(joint)
    limits = robot.joints[j].limits
    angles = np.arange(limits.min_deg, limits.max_deg + GRID_STEP_DEG / 2, GRID_STEP_DEG)
    data = start_state(model, index, np.asarray(pose_deg, dtype=float))
    dof, address = int(index.dof[j]), int(index.qpos[j])
    near = _chain_neighbours(model, index, j)
    beyond = sorted({b for n in near for b in _chain_neighbours(model, index, n)} - {j, *near})
    others = near + beyond
    # the joint first, then its neighbours and theirs: mass matrix, gravity and its slopes
    dofs = [dof] + [int(index.dof[n]) for n in others]
    mass = np.empty((len(angles), len(dofs), len(dofs)))
    gravity = np.empty((len(angles), len(dofs)))
    slopes = np.empty((len(angles), len(dofs), len(others)))
    # M·e: mj_mulM takes the same arguments in every MuJoCo choreo allows, where mj_fullM's
    # changed in 4.0 (data in place of its qM)
    units, column = np.eye(model.nv), np.zeros(model.nv)
    for k, angle in enumerate(angles):
        data.qpos[address] = np.radians(angle)
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        gravity[k] = -data.qfrc_bias[dofs]  # at rest the bias is gravity alone
        for a, row in enumerate(dofs):
            mujoco.mj_mulM(model, data, column, units[row])
            mass[k, a] = column[dofs]
        for n, other in enumerate(others):  # each moves the neighbour and steps forward
            slopes[k, :, n] = _gravity_slopes(model, data, dofs, int(index.qpos[other]))
    inertia = mass[:, 0, 0]
    own_at_pose = np.array(
        [np.interp(pose_deg[j], angles, mass[:, n, n]) for n in range(1, len(near) + 1)]
    )
    kept = _strongly_coupled(mass[:, 0, 1 : len(near) + 1].T, inertia, own_at_pose)
    carried = [
        len(near) + b
        for b in range(len(beyond))
        if any(_coupling_of(mass, 1 + n, 1 + len(near) + b) >= MIN_COUPLING for n in kept)
    ]

    def coupling(n: int) -> Coupling:
        return Coupling(
            robot.joint_names[others[n]],
            mass[:, 0, 1 + n],
            slopes[:, 0, n],
            gravity[:, 1 + n],
            params[others[n]],
        )

    among = np.array(kept + carried, dtype=int)
    among_mass = mass[:, 1:, 1:][:, among][:, :, among]
    among_slopes = slopes[:, 1:, :][:, among][:, :, among]
    friction = SoftFriction.of(model, dof)
    return JointLoad(
        joint,
        angles,
        inertia,
        gravity[:, 0],
        float(model.opt.timestep),
        friction,
        tuple(coupling(n) for n in kept),
        among_mass,
        among_slopes,
        tuple(coupling(n) for n in carried),
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


def _gravity_slopes(
    model: mujoco.MjModel, data: mujoco.MjData, dofs: list[int], address: int
) -> np.ndarray:
    """d(gravity torque on each of ``dofs``)/d(the angle at qpos ``address``), at rest,
    N·m/rad."""
    torque = []
    held = float(data.qpos[address])
    for shift in (SLOPE_STEP_RAD, -SLOPE_STEP_RAD):
        data.qpos[address] = held + shift
        mujoco.mj_forward(model, data)
        torque.append(-data.qfrc_bias[dofs])
    data.qpos[address] = held
    return (torque[0] - torque[1]) / (2 * SLOPE_STEP_RAD)


def _coupling_of(mass: np.ndarray, a: int, b: int) -> float:
    """How strongly two of ``mass``'s dofs are coupled over the grid: at most their mass
    matrix entry over the geometric mean of their own inertias."""
    return float(np.max(np.abs(mass[:, a, b]) / np.sqrt(mass[:, a, a] * mass[:, b, b])))


def _strongly_coupled(coupling: np.ndarray, inertia: np.ndarray, own: np.ndarray) -> list[int]:
    """Of the neighbours (rows of ``coupling``; ``own``: their own inertia where they hold),
    the MAX_NEIGHBOURS most strongly coupled to the joint, weaker than MIN_COUPLING left out."""
    strength = np.abs(coupling).max(axis=1, initial=0.0) / np.sqrt(own * inertia.max())
    ranked = sorted(range(len(own)), key=lambda n: -strength[n])
    return sorted(n for n in ranked[:MAX_NEIGHBOURS] if strength[n] >= MIN_COUPLING)
