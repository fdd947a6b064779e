"""The MuJoCo rollout of a tick list: servos in, recorded behaviour out.

Each physics step, every servo's own linear interpolation (``servo.ServoBank``) gives its
set-point; a MuJoCo position actuator per joint with forcerange = ± stall torque, kp, damping and
armature from the servo model (set on the compiled model, whatever the MJCF says) turns it into
torque, so lag and saturation look like the hardware. Everything the checks and the renderer need
is recorded in a ``Rollout``; nothing here judges it.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import mujoco
import numpy as np

from ..errors import PreviewError
from ..robot import Robot
from ..servos import POSITION_RANGE_UNITS
from .servo import (
    ActuatorParams,
    CommandStream,
    ServoBank,
    TickLike,
    UnitsToDeg,
    actuator_params,
    commanded_path_units,
    max_speed_units_s,
)

log = logging.getLogger(__name__)

HOME_KEY = "home"
NO_CONTACT, SELF_CONTACT, FLOOR_CONTACT = 0, 1, 2


@dataclass(frozen=True)
class SimSettings:
    settle_s: float = 0.5  # servos hold the first pose this long before the motion starts
    tail_s: float = 0.5  # keep simulating after the last move is due to finish
    min_contact_depth_m: float = 0.0  # shallower touches are not reported
    # joint name -> {ActuatorParams field: value}: the robot's measured servo, if it has one
    actuator_overrides: Mapping[str, Mapping[str, float]] | None = None

    def __post_init__(self) -> None:
        for name in ("settle_s", "tail_s", "min_contact_depth_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value!r}")


@dataclass(frozen=True)
class ContactPair:
    """Two links touching that should not: ``kind`` is "self" or "floor"."""

    kind: str
    body_a: str
    body_b: str


@dataclass(frozen=True)
class Rollout:
    """What happened, sampled at every physics step from t = 0 (the motion's start)."""

    robot: Robot
    times_s: np.ndarray  # (n,)
    position_deg: np.ndarray  # (n, joints) the joints' real angles
    setpoint_deg: np.ndarray  # (n, joints) where each servo's own interpolation is
    command_deg: np.ndarray  # (n, joints) the path the ticks ask for (no load, no lag)
    torque_nm: np.ndarray  # (n, joints) actuator torque
    qpos: np.ndarray  # (n, nq) full MuJoCo state, for rendering
    actuators: tuple[ActuatorParams, ...]
    contact_pairs: tuple[ContactPair, ...]
    contact_step: np.ndarray  # (k,) step index of each recorded contact
    contact_pair: np.ndarray  # (k,) index into contact_pairs
    contact_depth_m: np.ndarray  # (k,) penetration depth
    commands_end_s: float  # when the last commanded move is due to finish
    keyframe_times_s: tuple[float, ...] = ()
    root_body: str | None = None  # free-floating robots: the body carrying the free joint
    root_height_m: np.ndarray | None = None  # (n,)
    root_tilt_deg: np.ndarray | None = None  # (n,) angle between its z axis and the vertical

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def stall_torque_nm(self) -> np.ndarray:
        return np.array([a.stall_torque_nm for a in self.actuators])


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
        raise PreviewError(f"robot {robot.name} has no MuJoCo model: add mjcf (and scene) to "
                           f"{robot.path}")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as error:
        raise PreviewError(f"{path}: MuJoCo cannot load it: {error}") from None


def index_joints(model: mujoco.MjModel, robot: Robot) -> JointIndex:
    qpos, dof, actuator = [], [], []
    for joint in robot.joints:
        joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
        if joint_id < 0:
            raise PreviewError(f"joint {joint.name}: MJCF joint {joint.mjcf_joint!r} not found in "
                               f"{robot.scene_path or robot.mjcf_path}")
        drives = [a for a in range(model.nu)
                  if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
                  and model.actuator_trnid[a, 0] == joint_id]
        if len(drives) != 1:
            raise PreviewError(f"joint {joint.name}: MJCF joint {joint.mjcf_joint!r} needs exactly "
                               f"one actuator, found {len(drives)}")
        qpos.append(model.jnt_qposadr[joint_id])
        dof.append(model.jnt_dofadr[joint_id])
        actuator.append(drives[0])
    return JointIndex(np.array(qpos), np.array(dof), np.array(actuator))


def apply_servo_models(model: mujoco.MjModel, index: JointIndex,
                       params: Sequence[ActuatorParams], to_deg: UnitsToDeg) -> None:
    """Make every actuator the servo it stands for: a position servo with the servo model's
    kp, torque limit, damping and armature, able to aim anywhere in the servo's 0..1000 range
    (so a target past a joint limit pushes against the stop, as it would on the robot)."""
    servo_range_rad = np.radians(to_deg.deg(np.array(POSITION_RANGE_UNITS, dtype=float)[:, None]))
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


def free_root_body(model: mujoco.MjModel) -> int | None:
    """The body carrying the model's free joint, if it has one."""
    for joint_id in range(model.njnt):
        if model.jnt_type[joint_id] == mujoco.mjtJoint.mjJNT_FREE:
            return int(model.jnt_bodyid[joint_id])
    return None


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


def start_state(model: mujoco.MjModel, index: JointIndex,
                initial_deg: np.ndarray) -> mujoco.MjData:
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


def simulate(robot: Robot, ticks: Sequence[TickLike], initial_deg: Sequence[float],
             keyframe_times_s: Sequence[float] = (),
             settings: SimSettings = SimSettings()) -> Rollout:
    """Play ``ticks`` (what the bus will send) to the simulated robot, starting at rest at
    ``initial_deg`` (robot joint order; the player approaches the first pose before starting)."""
    n_joints = len(robot.joints)
    initial_deg = np.asarray(initial_deg, dtype=float)
    if initial_deg.shape != (n_joints,):
        raise ValueError(f"initial_deg needs {n_joints} angles (robot joint order), "
                         f"got {initial_deg.shape[0] if initial_deg.ndim else 'a scalar'}")
    stream = CommandStream.from_ticks(ticks, n_joints)
    params = actuator_params(robot, settings.actuator_overrides)
    to_deg = UnitsToDeg.for_joints(robot.joints)

    model = load_model(robot)
    index = index_joints(model, robot)
    apply_servo_models(model, index, params, to_deg)
    data = start_state(model, index, initial_deg)
    root = free_root_body(model)
    kinds = contact_kinds(model, free_floating=root is not None)
    labels = geom_labels(model)
    on_world = model.geom_bodyid == 0

    dt = float(model.opt.timestep)
    initial_units = to_deg.units(initial_deg)
    servos = ServoBank(initial_units, max_speed_units_s(params))
    ctrl = np.radians(initial_deg)
    for _ in range(round(settings.settle_s / dt)):
        data.ctrl[index.actuator] = ctrl
        mujoco.mj_step(model, data)

    end_s = stream.end_s + settings.tail_s
    n = int(math.floor(end_s / dt + 1e-9)) + 1
    times = np.arange(n) * dt
    recorder = _Recorder(n, n_joints, model.nq, root is not None)
    pair_ids: dict[tuple[int, str, str], int] = {}
    next_tick = 0
    for step in range(n):
        t = times[step]
        position_deg = np.degrees(data.qpos[index.qpos])
        while next_tick < len(stream.start_s) and stream.start_s[next_tick] <= t + 1e-9:
            servos.start(stream, next_tick, t, to_deg.units(position_deg))
            next_tick += 1
        setpoint_deg = to_deg.deg(servos.setpoint_units(t))
        data.ctrl[index.actuator] = np.radians(setpoint_deg)
        recorder.qpos[step] = data.qpos
        mujoco.mj_step(model, data)  # forces and contacts below belong to the state at t
        recorder.position_deg[step] = position_deg
        recorder.setpoint_deg[step] = setpoint_deg
        recorder.torque_nm[step] = data.actuator_force[index.actuator]
        if root is not None:
            recorder.root_height_m[step] = data.xpos[root, 2]
            recorder.root_cos_tilt[step] = data.xmat[root, 8]
        if data.ncon:
            _record_contacts(data, kinds, labels, on_world, settings.min_contact_depth_m,
                             step, pair_ids, recorder)

    pairs = [ContactPair("self" if kind == SELF_CONTACT else "floor", a, b)
             for (kind, a, b) in sorted(pair_ids, key=pair_ids.get)]
    command_deg = to_deg.deg(commanded_path_units(stream, initial_units, times))
    return Rollout(
        robot=robot,
        times_s=times,
        position_deg=recorder.position_deg,
        setpoint_deg=recorder.setpoint_deg,
        command_deg=command_deg,
        torque_nm=recorder.torque_nm,
        qpos=recorder.qpos,
        actuators=params,
        contact_pairs=tuple(pairs),
        contact_step=np.array(recorder.contact_step, dtype=int),
        contact_pair=np.array(recorder.contact_pair, dtype=int),
        contact_depth_m=np.array(recorder.contact_depth_m, dtype=float),
        commands_end_s=stream.end_s,
        keyframe_times_s=tuple(float(t) for t in keyframe_times_s),
        root_body=link_name(model, root) if root is not None else None,
        root_height_m=recorder.root_height_m,
        root_tilt_deg=(np.degrees(np.arccos(np.clip(recorder.root_cos_tilt, -1.0, 1.0)))
                       if root is not None else None),
    )


class _Recorder:
    """Preallocated arrays the loop fills in."""

    def __init__(self, n: int, n_joints: int, nq: int, free_floating: bool):
        self.position_deg = np.empty((n, n_joints))
        self.setpoint_deg = np.empty((n, n_joints))
        self.torque_nm = np.empty((n, n_joints))
        self.qpos = np.empty((n, nq))
        self.root_height_m = np.empty(n) if free_floating else None
        self.root_cos_tilt = np.empty(n) if free_floating else None
        self.contact_step: list[int] = []
        self.contact_pair: list[int] = []
        self.contact_depth_m: list[float] = []


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


def _record_contacts(data: mujoco.MjData, kinds: np.ndarray, labels: Sequence[str],
                     on_world: np.ndarray, min_depth_m: float, step: int,
                     pair_ids: dict[tuple[int, str, str], int], recorder: _Recorder) -> None:
    contact = data.contact
    geoms = contact.geom[: data.ncon]
    depth = -contact.dist[: data.ncon]
    kind = kinds[geoms[:, 0], geoms[:, 1]]
    for i in np.flatnonzero((kind != NO_CONTACT) & (depth > min_depth_m)):
        g1, g2 = int(geoms[i, 0]), int(geoms[i, 1])
        if kind[i] == FLOOR_CONTACT:
            names = (labels[g2], labels[g1]) if on_world[g1] else (labels[g1], labels[g2])
        else:
            names = tuple(sorted((labels[g1], labels[g2])))
        key = (int(kind[i]), *names)
        recorder.contact_step.append(step)
        recorder.contact_pair.append(pair_ids.setdefault(key, len(pair_ids)))
        recorder.contact_depth_m.append(float(depth[i]))
