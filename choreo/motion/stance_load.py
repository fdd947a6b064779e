"""What the legs on the floor must hold up: the torque each joint needs to carry the robot's
weight in a stance, against its servo's stall torque at the supply the robot runs on.

A gait fast enough for the joints' speed can still be too heavy for them: with three feet down
instead of six each carries twice the weight, and a servo at a low supply has less torque (in
proportion to the supply, as the preview has it). Statics, no physics: the weight, at the centre
of mass, is shared by the feet down as evenly as balance allows (the least-squares forces that
sum to the weight and put its moment about the centre of mass to nought), and each joint holds
the moment of its foot's share about its axis (the foot's Jacobian, by finite differences).
The legs' own swing and the body's acceleration are left out: at a gait's pace they are small
against the weight, and a stance that fails statically fails walking too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from choreo.bus.servo_models import SERVO_MODELS
from choreo.robot.types import Joint, Robot

if TYPE_CHECKING:
    from choreo.robot.kinematics import Kinematics

GRAVITY_M_S2 = 9.81
DOWN_MM = 1.0  # a foot this close to the lowest is on the floor
STEP_RAD = 1e-4  # the finite difference of the feet's Jacobian


@dataclass(frozen=True)
class Overload:
    """The joint that needs most of its stall torque in a stance, where it needs more."""

    joint: str
    needed_nm: float
    stall_nm: float  # at the supply
    supply_v: float | None  # as the robot file declares it (None: the servo's rated one)
    feet_down: int
    mass_kg: float
    keyframe: int  # index among the stances judged


def stall_torque_nm(robot: Robot, joint: Joint) -> float:
    """``joint``'s servo's stall torque at the supply the robot file declares (its own or its
    measured figure if it has one, at the servo's rated supply, scaled as the preview does)."""
    model = SERVO_MODELS[joint.servo_model]
    rated = joint.actuator.get("stall_torque_nm", model.stall_torque_nm)
    return rated * model.supply_scale(robot.declared_supply_v(joint))


def worst_overload(
    kin: Kinematics, feet: Sequence[str], stances_deg: Sequence[np.ndarray]
) -> Overload | None:
    """The stance (joint angles, robot order) and joint where the weight needs the most over
    its servo's stall torque, or None if every joint holds every stance."""
    robot = kin.robot
    stall = np.array([stall_torque_nm(robot, joint) for joint in robot.joints])
    mass_kg = float(kin.model.body_mass.sum())
    worst: Overload | None = None
    legs, apart = None, None
    for index, angles in enumerate(stances_deg):
        angles = np.asarray(angles, dtype=float)
        if legs is None:
            legs = _legs_of(kin, feet, angles)
            # all the legs apart: so are those of the feet down in any stance (else see there)
            apart = _apart(kin, feet, [legs[foot] for foot in feet]) or None
        needed, down = holding_torques_nm(kin, feet, angles, mass_kg, legs, apart=apart)
        over = np.abs(needed) / stall
        j = int(np.argmax(over))
        if over[j] > 1 and (worst is None or over[j] > worst.needed_nm / worst.stall_nm):
            supply = robot.declared_supply_v(robot.joints[j])
            worst = Overload(
                robot.joint_names[j], float(abs(needed[j])), float(stall[j]), supply, down,
                mass_kg, index,
            )  # fmt: skip
    return worst


def holding_torques_nm(
    kin: Kinematics,
    feet: Sequence[str],
    angles_deg: np.ndarray,
    mass_kg: float,
    legs: dict[str, np.ndarray] | None = None,
    *,
    apart: bool | None = None,
) -> tuple[np.ndarray, int]:
    """Each joint's torque (N·m, robot order) to hold the robot up on its feet down at
    ``angles_deg`` (the body level), and how many feet are down; ``legs``: the joints that
    move each foot (found here if not given); ``apart``: whether the legs of the feet down
    hang apart (see ``_lifts_per_rad``; found here if not given)."""
    feet_m = kin.site_positions_mm(feet, angles_deg) / 1000  # (the bodies posed there too)
    down = feet_m[:, 2] <= feet_m[:, 2].min() + DOWN_MM / 1000
    masses = kin.model.body_mass
    centre_world = (masses[:, None] * kin.data.xipos).sum(axis=0) / masses.sum()
    centre_m = kin.world_to_base_mm(centre_world * 1000) / 1000
    # the feet's upward forces: summing to the weight, balanced about the centre of mass
    balance = np.vstack([np.ones(int(down.sum())), feet_m[down, 0], feet_m[down, 1]])
    weight = mass_kg * GRAVITY_M_S2
    forces = np.linalg.lstsq(balance, weight * np.array([1.0, *centre_m[:2]]), rcond=None)[0]
    standing = [feet[int(foot)] for foot in np.flatnonzero(down)]
    if legs is None:
        legs = _legs_of(kin, standing, angles_deg)
    joints = [legs[foot] for foot in standing]
    if apart is None:
        apart = _apart(kin, standing, joints)
    lifts = _lifts_per_rad(kin, angles_deg, standing, feet_m[down, 2], joints, apart)
    torques = np.zeros(len(angles_deg))
    for lift, force in zip(lifts, forces):
        torques += lift * force
    return torques, int(down.sum())


def _legs_of(kin: Kinematics, feet: Sequence[str], angles_deg: np.ndarray) -> dict[str, np.ndarray]:
    """The joints (robot order) that move each of ``feet``: its leg's (each joint turned alone,
    every foot read from the same pose)."""
    base_m = kin.site_positions_mm(feet, angles_deg)[:, 2] / 1000
    rows = np.zeros((len(feet), len(angles_deg)))
    for j in range(len(angles_deg)):
        rows[:, j] = _lifted_m(kin, feet, angles_deg, [j], base_m)
    return {foot: np.flatnonzero(row != 0) for foot, row in zip(feet, rows)}


def _lifts_per_rad(
    kin: Kinematics,
    angles_deg: np.ndarray,
    feet: Sequence[str],
    base_m: np.ndarray,
    joints: list[np.ndarray],
    apart: bool,
) -> np.ndarray:
    """How far each joint of each foot's leg raises that foot per radian (m/rad; one row per
    foot, 0 for the joints of other legs): the vertical row of the foot's Jacobian, which times
    the floor's push on the foot is the torque the joint holds.

    Legs that hang apart (no joint of one moves another's foot) have their first joints turned
    together, then their second and so on: each foot moves by its own joint as if turned alone
    (MuJoCo poses a body from its own joints and its parents' only), for a few forward
    kinematics per stance instead of one per joint; others each joint alone."""
    rows = np.zeros((len(feet), len(angles_deg)))
    if apart:
        rounds = [
            [(f, leg[k]) for f, leg in enumerate(joints) if k < len(leg)]
            for k in range(max(map(len, joints), default=0))
        ]
    else:
        rounds = [[(f, j)] for f, leg in enumerate(joints) for j in leg]
    for turned in rounds:
        lifted = _lifted_m(kin, feet, angles_deg, [j for _, j in turned], base_m)
        for f, j in turned:
            rows[f, j] = lifted[f]
    return rows


def _lifted_m(
    kin: Kinematics,
    feet: Sequence[str],
    angles_deg: np.ndarray,
    turned: list[int],
    base_m: np.ndarray,
) -> np.ndarray:
    """How far every foot rises per radian with the ``turned`` joints each turned STEP_RAD."""
    moved = angles_deg.copy()
    moved[turned] += np.degrees(STEP_RAD)
    return (kin.site_positions_mm(feet, moved)[:, 2] / 1000 - base_m) / STEP_RAD


def _apart(kin: Kinematics, feet: Sequence[str], legs: list[np.ndarray]) -> bool:
    """No joint of one foot's leg is on another foot's chain of bodies."""
    model = kin.model
    chains = []
    for foot in feet:
        body, chain = int(model.site_bodyid[kin.site_id(foot)]), set()
        while body > 0:
            chain.add(body)
            body = int(model.body_parentid[body])
        chains.append(chain)
    joints = kin.robot.joints
    bodies = [{int(model.joint(joints[j].mjcf_joint).bodyid[0]) for j in leg} for leg in legs]
    return not any(
        bodies[a] & chains[b] for a in range(len(feet)) for b in range(len(feet)) if a != b
    )
