"""The compiled MuJoCo model as the preview uses it: joints found, servos applied, links named.

The model's actuators are made into the servos they stand for (kp, torque limit, damping,
armature from the servo model) on the compiled model, whatever the MJCF says.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.bus.servo_models import POSITION_RANGE_UNITS
from choreo.errors import PreviewError
from choreo.motion.scene import Prop
from choreo.preview.actuator import ActuatorParams
from choreo.robot.compiled_model import compiled_model
from choreo.robot.types import Robot

HOME_KEY = "home"
# what a contact between two geoms means: nothing to report; two links that are not parent and
# child; a fixed robot's link on a world geom; a parent and child link (the self-collision
# check skips them, but MuJoCo simulates contacts with the world and its welded bodies); a
# free-floating robot's link, other than a foot, on the floor or a prop; a foot there (walking,
# unless the plan has that foot in the air)
NO_CONTACT, SELF_CONTACT, FLOOR_CONTACT, NEIGHBOUR_CONTACT, GROUND_CONTACT = 0, 1, 2, 3, 4
FOOT_CONTACT = 5
HELD_CONTACT = 6  # a robot link on a free prop: expected (pushed, gripped, carried), recorded
PROP_RGBA = (0.72, 0.55, 0.35, 1.0)
FREE_PROP_RGBA = (0.85, 0.3, 0.25, 1.0)
PROP_JOINT_PREFIX = "choreo_prop:"  # a free prop's joint: its body is not the robot's


@dataclass(frozen=True)
class JointIndex:
    """Where each robot joint (robot order) lives in the compiled model."""

    qpos: np.ndarray
    dof: np.ndarray
    actuator: np.ndarray


def load_model(robot: Robot, props: Sequence[Prop] = ()) -> mujoco.MjModel:
    """The robot's scene (floor and light) or, without one, its bare MJCF; ``props`` are added
    as boxes fixed in the world, or free bodies (named as the prop) for those with a mass."""
    path = robot.scene_path or robot.mjcf_path
    if path is None:
        raise PreviewError(
            f"robot {robot.name} has no MuJoCo model: add mjcf (and scene) to {robot.path}"
        )
    try:
        if not props:
            return compiled_model(path)
        spec = mujoco.MjSpec.from_file(str(path))
        taken = {geom.name for geom in spec.geoms if geom.name}
        for prop in props:
            if prop.name in taken:  # MuJoCo would blame the scene file for the motion's name
                raise PreviewError(
                    f"{prop.where or prop.name}: props: the name {prop.name!r} is taken by a "
                    f"part of the robot or its scene ({path.name}); choose another name"
                )
            _add_prop(spec, prop)
        model = spec.compile()
    except ValueError as error:
        raise PreviewError(f"{path}: MuJoCo cannot load it: {error}") from None
    _start_props_in_place(model)
    if any(prop.free for prop in props):
        _hold_what_friction_holds(model)
    return model


def model_digest(model: mujoco.MjModel) -> str:
    """A digest of what the physics reads of a compiled model: its arrays (masses, geometry,
    joints, actuators, ...) and its options, not the textures' pixels. Two loads of the same
    files give the same digest; an edit to the MJCF that changes the physics changes it (the
    robot file itself may not change)."""
    digest = hashlib.blake2b(digest_size=16)
    for name in dir(model):
        value = getattr(model, name) if not name.startswith("_") and name != "tex_data" else None
        if isinstance(value, np.ndarray):
            digest.update(name.encode() + value.tobytes())
    for name in dir(model.opt):
        value = getattr(model.opt, name) if not name.startswith("_") else None
        if isinstance(value, (int, float, np.ndarray)):
            digest.update(name.encode() + np.asarray(value, dtype=float).tobytes())
    return digest.hexdigest()


GRASP_IMPRATIO = 10.0  # friction constraints this much stiffer than normal ones (MuJoCo's 1)


def _hold_what_friction_holds(model: mujoco.MjModel) -> None:
    """Contacts that keep a gripped prop where friction keeps it. With MuJoCo's defaults
    (pyramidal cones, soft friction as stiff as the normal force), a block squeezed with twice
    the friction its weight needs creeps 14 mm down through the fingers while it is carried;
    with elliptic cones and friction ten times stiffer it moves 3.4 mm in the hand (a 20 g one
    2.7 mm: the soft pads), and one with half the friction it needs still slips out
    (``tests/preview/test_model.py``). Only scenes with a free prop: a walker's feet on the
    floor keep the settings its gaits were tuned with."""
    model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    model.opt.impratio = GRASP_IMPRATIO


def _add_prop(spec: mujoco.MjSpec, prop: Prop) -> None:
    x, y, z = prop.at_m
    half_yaw = np.radians(prop.yaw_deg) / 2
    centre = [x, y, z + prop.size_m[2] / 2]
    turn = [np.cos(half_yaw), 0.0, 0.0, np.sin(half_yaw)]
    if prop.mass_kg is None:
        geom = spec.worldbody.add_geom()
        geom.pos, geom.quat, geom.rgba = centre, turn, PROP_RGBA
    else:
        body = spec.worldbody.add_body()
        body.name = prop.name
        body.pos, body.quat = centre, turn
        body.add_freejoint().name = PROP_JOINT_PREFIX + prop.name
        geom = body.add_geom()
        geom.mass, geom.rgba = prop.mass_kg, FREE_PROP_RGBA
        if prop.friction is not None:
            geom.friction = [prop.friction, *geom.friction[1:]]
    geom.name = prop.name
    geom.type = mujoco.mjtGeom.mjGEOM_BOX
    geom.size = [size / 2 for size in prop.size_m]


def _start_props_in_place(model: mujoco.MjModel) -> None:
    """Each free prop in the scene's keyframes (the home pose the preview starts from) where the
    motion puts it: the scene's keyframes know nothing of the props, and MuJoCo before 3.15
    fills a joint added to them with zeros, the world's origin."""
    for joint in free_prop_joints(model).values():
        address = model.jnt_qposadr[joint]
        model.key_qpos[:, address : address + 7] = model.qpos0[address : address + 7]


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
    kp, torque limit, damping, armature and dry friction, able to aim anywhere in the servo's
    0..1000 range (so a target past a joint limit pushes against the stop, as it would on the
    robot)."""
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
        model.dof_frictionloss[d] = p.friction_nm


def free_joint(model: mujoco.MjModel) -> int | None:
    """The robot's free joint (a free-floating robot's root), if it has one."""
    for joint_id in range(model.njnt):
        if model.jnt_type[joint_id] == mujoco.mjtJoint.mjJNT_FREE and not _is_prop_joint(
            model, joint_id
        ):
            return joint_id
    return None


def _is_prop_joint(model: mujoco.MjModel, joint_id: int) -> bool:
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint_id) or ""
    return name.startswith(PROP_JOINT_PREFIX)


def free_prop_joints(model: mujoco.MjModel) -> dict[str, int]:
    """Each free prop's name -> its free joint."""
    return {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)[len(PROP_JOINT_PREFIX) :]: j
        for j in range(model.njnt)
        if _is_prop_joint(model, j)
    }


def robot_body_mask(model: mujoco.MjModel) -> np.ndarray:
    """(nbody,) True for the robot's bodies: not the world, not a free prop."""
    mask = np.ones(model.nbody, dtype=bool)
    mask[0] = False
    for joint in free_prop_joints(model).values():
        mask[model.jnt_bodyid[joint]] = False
    return mask


def link_of_body(model: mujoco.MjModel) -> np.ndarray:
    """Each body's link: the body its rigid group hangs from. Bodies welded to the world (a
    fixed robot's base) form the link of the robot's root body; the world itself is link 0."""
    links = model.body_weldid.copy()
    for body in range(1, model.nbody):
        if links[body] == 0:
            links[body] = model.body_rootid[body]
    return links


def contact_kinds(
    model: mujoco.MjModel, free_floating: bool, feet: Sequence[int] = ()
) -> np.ndarray:
    """(ngeom, ngeom) matrix of what each geom pair's contact means (the ``*_CONTACT`` kinds);
    ``feet`` are a free-floating robot's foot links, whose touching the ground is walking. A free
    prop touching anything is expected: it is there to be pushed, gripped and carried (the
    robot's links on it are recorded as held, to tell a servo squeezing it from one stalled)."""
    links = link_of_body(model)
    parent_link = np.array([links[model.body_parentid[link]] for link in range(model.nbody)])
    geom_link = links[model.geom_bodyid]
    a, b = geom_link[:, None], geom_link[None, :]
    on_robot = robot_body_mask(model)[model.geom_bodyid]
    free_prop = ~on_robot & (model.geom_bodyid != 0)
    on_world = ~on_robot
    world_a, world_b = on_world[:, None], on_world[None, :]
    robot_pair = ~world_a & ~world_b
    neighbours = (parent_link[a] == b) | (parent_link[b] == a)
    kinds = np.where(robot_pair & (a != b) & ~neighbours, SELF_CONTACT, NO_CONTACT)
    kinds = np.where(robot_pair & (a != b) & neighbours, NEIGHBOUR_CONTACT, kinds)
    robot_on_world = (world_a & ~world_b) | (world_b & ~world_a)
    if free_floating:
        foot = np.isin(geom_link, list(feet))
        on_foot = foot[None, :] | foot[:, None]
        kinds = np.where(robot_on_world & ~on_foot, GROUND_CONTACT, kinds)
        kinds = np.where(robot_on_world & on_foot, FOOT_CONTACT, kinds)
    else:
        base = np.isin(geom_link, np.unique(model.body_rootid[1:]))
        floor = robot_on_world & ~(base[None, :] | base[:, None])
        kinds = np.where(floor, FLOOR_CONTACT, kinds)
    kinds = np.where(free_prop[:, None] | free_prop[None, :], NO_CONTACT, kinds)
    held = (free_prop[:, None] & on_robot[None, :]) | (on_robot[:, None] & free_prop[None, :])
    kinds = np.where(held, HELD_CONTACT, kinds)
    return kinds.astype(np.int8)


def link_name(model: mujoco.MjModel, link: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, link) or f"body {link}"


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
