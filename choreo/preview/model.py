"""The compiled MuJoCo model as the preview uses it: joints found, servos applied, links named.

The model's actuators are made into the servos they stand for (kp, torque limit, damping,
armature from the servo model) on the compiled model, whatever the MJCF says.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import PreviewError
from ..robot import Robot
from ..servos import POSITION_RANGE_UNITS
from .servo import ActuatorParams

HOME_KEY = "home"
NO_CONTACT, SELF_CONTACT, FLOOR_CONTACT = 0, 1, 2


@dataclass(frozen=True)
class JointIndex:
    """Where each robot joint (robot order) lives in the compiled model."""

    qpos: np.ndarray
    dof: np.ndarray
    actuator: np.ndarray


def load_model(robot: Robot) -> mujoco.MjModel:
    """The robot's scene (floor and light) or, without one, its bare MJCF."""
    path = robot.scene_path or robot.mjcf_path
    if path is None:
        raise PreviewError(
            f"robot {robot.name} has no MuJoCo model: add mjcf (and scene) to {robot.path}"
        )
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as error:
        raise PreviewError(f"{path}: MuJoCo cannot load it: {error}") from None


def index_joints(model: mujoco.MjModel, robot: Robot) -> JointIndex:
    qpos, dof, actuator = [], [], []
    for joint in robot.joints:
        joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
        if joint_id < 0:
            raise PreviewError(
                f"joint {joint.name}: MJCF joint {joint.mjcf_joint!r} not found in "
                f"{robot.scene_path or robot.mjcf_path}"
            )
        drives = [
            a
            for a in range(model.nu)
            if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
            and model.actuator_trnid[a, 0] == joint_id
        ]
        if len(drives) != 1:
            raise PreviewError(
                f"joint {joint.name}: MJCF joint {joint.mjcf_joint!r} needs exactly "
                f"one actuator, found {len(drives)}"
            )
        qpos.append(model.jnt_qposadr[joint_id])
        dof.append(model.jnt_dofadr[joint_id])
        actuator.append(drives[0])
    return JointIndex(np.array(qpos), np.array(dof), np.array(actuator))


def apply_servo_models(
    model: mujoco.MjModel, index: JointIndex, params: Sequence[ActuatorParams], robot: Robot
) -> None:
    """Make every actuator the servo it stands for: a position servo with the servo model's
    kp, torque limit, damping and armature, able to aim anywhere in the servo's 0..1000 range
    (so a target past a joint limit pushes against the stop, as it would on the robot)."""
    servo_range_rad = np.radians(robot.to_deg(np.array(POSITION_RANGE_UNITS, dtype=float)[:, None]))
    for j, p in enumerate(params):
        a, d = index.actuator[j], index.dof[j]
        model.actuator_dyntype[a] = mujoco.mjtDyn.mjDYN_NONE
        model.actuator_gaintype[a] = mujoco.mjtGain.mjGAIN_FIXED
        model.actuator_biastype[a] = mujoco.mjtBias.mjBIAS_AFFINE
        model.actuator_gear[a] = [1, 0, 0, 0, 0, 0]
        model.actuator_gainprm[a, :3] = [p.kp_nm_rad, 0, 0]
        model.actuator_biasprm[a, :3] = [0, -p.kp_nm_rad, 0]
        model.actuator_forcelimited[a] = 1
        model.actuator_forcerange[a] = [-p.stall_torque_nm, p.stall_torque_nm]
        model.actuator_ctrllimited[a] = 1
        model.actuator_ctrlrange[a] = np.sort(servo_range_rad[:, j])
        model.dof_damping[d] = p.damping_nm_s_rad
        model.dof_armature[d] = p.armature_kg_m2


def free_joint(model: mujoco.MjModel) -> int | None:
    """The model's free joint (a free-floating robot's root), if it has one."""
    for joint_id in range(model.njnt):
        if model.jnt_type[joint_id] == mujoco.mjtJoint.mjJNT_FREE:
            return joint_id
    return None


def free_root_body(model: mujoco.MjModel) -> int | None:
    """The body carrying the model's free joint, if it has one."""
    joint_id = free_joint(model)
    return None if joint_id is None else int(model.jnt_bodyid[joint_id])


def link_of_body(model: mujoco.MjModel) -> np.ndarray:
    """Each body's link: the body its rigid group hangs from. Bodies welded to the world (a
    fixed robot's base) form the link of the robot's root body; the world itself is link 0."""
    links = model.body_weldid.copy()
    for body in range(1, model.nbody):
        if links[body] == 0:
            links[body] = model.body_rootid[body]
    return links


def contact_kinds(model: mujoco.MjModel, free_floating: bool) -> np.ndarray:
    """(ngeom, ngeom) matrix: which geom pairs are a self-collision (links that are not parent
    and child) or a floor contact (a fixed robot's link, other than its base, on a world geom)."""
    links = link_of_body(model)
    parent_link = np.array([links[model.body_parentid[link]] for link in range(model.nbody)])
    geom_link = links[model.geom_bodyid]
    a, b = geom_link[:, None], geom_link[None, :]
    on_world = model.geom_bodyid == 0
    world_a, world_b = on_world[:, None], on_world[None, :]
    robot_pair = ~world_a & ~world_b
    adjacent = (a == b) | (parent_link[a] == b) | (parent_link[b] == a)
    kinds = np.where(robot_pair & ~adjacent, SELF_CONTACT, NO_CONTACT)
    if not free_floating:
        base = np.isin(geom_link, np.unique(model.body_rootid[1:]))
        floor = (world_a & ~world_b & ~base[None, :]) | (world_b & ~world_a & ~base[:, None])
        kinds = np.where(floor, FLOOR_CONTACT, kinds)
    return kinds.astype(np.int8)


def link_name(model: mujoco.MjModel, link: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, link) or f"body {link}"


def start_state(model: mujoco.MjModel, index: JointIndex, initial_deg: np.ndarray) -> mujoco.MjData:
    """The MJCF's ``home`` keyframe (for a free-floating robot: where its body stands), with the
    robot's joints at the motion's first pose."""
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    data.qpos[index.qpos] = np.radians(initial_deg)
    data.qvel[:] = 0.0
    data.ctrl[index.actuator] = np.radians(initial_deg)
    mujoco.mj_forward(model, data)
    return data


def geom_labels(model: mujoco.MjModel) -> list[str]:
    """What to call each geom in a message: its link's name, or for world geoms their own name."""
    links = link_of_body(model)
    labels = []
    for geom in range(model.ngeom):
        body = model.geom_bodyid[geom]
        if body == 0:
            labels.append(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or "world")
        else:
            labels.append(link_name(model, int(links[body])))
    return labels
