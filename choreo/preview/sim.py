"""The MuJoCo rollout of a tick list: servos in, recorded behaviour out.

Each physics step, every servo's own linear interpolation (``actuator.ServoBank``) gives its
set-point; the model's position actuators, made into the servo model (``preview/model.py``), turn
it into torque, so lag and saturation look like the hardware. Everything the checks and the
renderer need is recorded in a ``Rollout``; nothing here judges it, and nothing here knows the
motion the ticks came from (``pipeline.py`` measures the rollout against it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from choreo.core.arguments import NON_NEGATIVE, Range, check_member, check_number
from choreo.motion.scene import Prop, StartPosture
from choreo.plan.ticks import Tick
from choreo.preview.actuator import (
    CommandStream,
    ServoBank,
    ServoDrive,
    actuator_params,
    checked_overrides,
    commanded_path_units,
    max_speed_units_s,
)
from choreo.preview.contact_log import ContactLog
from choreo.preview.model import (
    apply_servo_models,
    free_joint,
    free_prop_joints,
    index_joints,
    link_name,
    link_of_body,
    load_model,
    model_digest,
)
from choreo.preview.rollout import FreeBody, MoveStart, Rollout, Settling
from choreo.preview.start import foot_links, start_state
from choreo.preview.step_loop import CHECKPOINT_S, Resume, StepLoop, StepRecord, check_stable
from choreo.robot.poses import HOME_POSE
from choreo.robot.types import Robot

# the settling before the motion and the tail after it: a minute of either is already a mistake
SIMULATED_S = Range(at_least=0, at_most=60.0, unit=" s")


@dataclass(frozen=True)
class SimSettings:
    max_settle_s: float = 2.0  # the start pose is held until the robot is still, at most this
    move_start: MoveStart = MoveStart.SETPOINT
    tail_s: float = 0.5  # keep simulating after the last move is due to finish
    min_contact_depth_m: float = 0.0  # touches this shallow or shallower are not recorded
    # joint name -> {ActuatorParams field: value}: the robot's measured servo, if it has one
    actuator_overrides: Mapping[str, Mapping[str, float]] | None = None

    def __post_init__(self) -> None:
        check_number("max_settle_s", self.max_settle_s, SIMULATED_S)
        object.__setattr__(
            self, "move_start", check_member("move_start", self.move_start, MoveStart)
        )
        check_number("tail_s", self.tail_s, SIMULATED_S)
        check_number("min_contact_depth_m", self.min_contact_depth_m, NON_NEGATIVE)
        checked_overrides(self.actuator_overrides)  # its joints: once the robot is known


def simulate(
    robot: Robot,
    ticks: Sequence[Tick],
    initial_deg: Sequence[float],
    keyframe_times_s: Sequence[float] = (),
    settings: SimSettings = SimSettings(),
    *,
    motion_start_s: float = 0.0,
    posture: StartPosture = StartPosture.STANDING,
    props: Sequence[Prop] = (),
    resume: Resume | None = None,
) -> Rollout:
    """Play ``ticks`` (what the bus will send) to the simulated robot, which starts at rest at
    ``initial_deg`` (robot joint order), held there until still. The motion itself starts
    ``motion_start_s`` into the ticks (after the approach), and times are counted from there.

    ``resume``, an earlier rollout's (of the same robot, start and settings): the steps before
    the first tick that differs are taken from it, and the physics runs on from its last
    checkpoint before that tick (the same, bit for bit); once the ticks left are its ticks and
    the simulator is as it was then (within ``step_loop.JOIN_TOLERANCE``), the rest is taken
    from it too."""
    # One straight recipe (build, settle or resume, run, record) whose length is the Rollout's
    # fields, one per line: split further, its parts would pass most of its locals around.
    n_joints = len(robot.joints)
    start_deg = _checked_start(initial_deg, n_joints)
    stream = CommandStream.from_ticks(ticks, n_joints)
    params = actuator_params(robot, settings.actuator_overrides)

    model = load_model(robot, props)
    index = index_joints(model, robot)
    apply_servo_models(model, index, params, robot)
    root = free_joint(model)
    feet: tuple[int, ...] = ()
    if root is not None and HOME_POSE in robot.poses:
        feet = foot_links(model, index, robot.pose_vector(HOME_POSE))
    data = start_state(model, index, start_deg, posture)
    dt = float(model.opt.timestep)
    drive = ServoDrive(params, dt, np.radians(start_deg))

    initial_units = robot.to_units(start_deg)
    servos = ServoBank(initial_units, max_speed_units_s(params))
    contacts = ContactLog(model, settings.min_contact_depth_m, feet)
    max_settle = round(settings.max_settle_s / dt)
    n_run = int(math.floor((stream.end_s + settings.tail_s) / dt + 1e-9)) + 1
    record = StepRecord(max_settle + n_run, model.nq, n_joints)
    loop = StepLoop(model, data, index, drive, contacts, record, _planar_root(model, root))
    # the model's digest too: an MJCF edited on disk leaves the robot file, and so ``robot``, as
    # it was
    inputs = (robot, tuple(start_deg), settings, posture, tuple(props), model_digest(model))
    checkpoint = None if resume is None else resume.checkpoint_for(inputs, tuple(ticks), dt, n_run)
    if resume is not None and checkpoint is not None:
        settled, n_settle = resume.settled, resume.n_settle
        servos = loop.restore(checkpoint, resume, n_settle)
        first = checkpoint.step
    else:
        settled = loop.settle(np.radians(start_deg), max_settle)
        n_settle, first = record.count, 0
    rejoin = None if resume is None else resume.rejoin(inputs, tuple(ticks), dt, n_settle, n_run)
    checkpoints = loop.run(
        stream, servos, robot, settings.move_start, n_run, first, round(CHECKPOINT_S / dt), rejoin
    )
    check_stable(model, data)
    if checkpoint is not None:
        checkpoints = [c for c in resume.checkpoints if c.step < first] + checkpoints  # type: ignore[union-attr]

    n = record.count
    stream_times = (np.arange(n) - n_settle) * dt
    body = None if root is None else _free_body(model, root, feet, record.qpos[:n])
    return Rollout(
        robot=robot,
        times_s=stream_times - motion_start_s,
        position_deg=np.degrees(record.qpos[:n, index.qpos]),
        setpoint_deg=np.degrees(record.ctrl[:n]),
        command_deg=robot.to_deg(commanded_path_units(stream, initial_units, stream_times)),
        torque_nm=record.torque[:n],
        qpos=record.qpos[:n],
        actuators=params,
        contacts=contacts.recorded(),
        commands_end_s=stream.end_s - motion_start_s,
        keyframe_times_s=tuple(float(t) for t in keyframe_times_s),
        body=body,
        approach_start_s=-motion_start_s,
        settling=_settling(body, n_settle, dt, settled),
        posture=posture,
        props=tuple(props),
        move_start=settings.move_start,
        joint_links=_joint_links(model, robot),
        prop_qpos_addresses=tuple(
            (name, int(model.jnt_qposadr[joint])) for name, joint in free_prop_joints(model).items()
        ),
        resume=Resume(
            inputs, tuple(ticks), settled, n_settle, record, contacts, tuple(checkpoints)
        ),
    )


def _planar_root(model: mujoco.MjModel, root: int | None) -> int | None:
    """Where a free-floating robot's root x and y are in qpos if nothing in the world tells one
    place on the floor from another: the world's geoms level planes, nothing else free or tied
    to the world, gravity straight down. None otherwise (a fixed robot, props)."""
    if root is None or free_prop_joints(model) or model.nmocap or model.neq:
        return None
    planes = model.geom_type[model.geom_bodyid == 0] == mujoco.mjtGeom.mjGEOM_PLANE
    tilts = model.geom_quat[model.geom_bodyid == 0][:, 1:3]  # a turn about z only: level
    level = not model.opt.gravity[:2].any() and not tilts.any()
    return int(model.jnt_qposadr[root]) if planes.all() and level else None


def _checked_start(initial_deg: Sequence[float], n_joints: int) -> np.ndarray:
    start_deg = np.asarray(initial_deg, dtype=float)
    if start_deg.shape != (n_joints,):
        raise ValueError(
            f"initial_deg needs {n_joints} angles (robot joint order), got shape {start_deg.shape}"
        )
    return start_deg


def _free_body(
    model: mujoco.MjModel, root: int, feet: tuple[int, ...], qpos: np.ndarray
) -> FreeBody:
    """The free-floating robot's root body (carrying the free joint ``root``), step by step."""
    address = int(model.jnt_qposadr[root])
    height, tilt = _root_pose(qpos, address)
    return FreeBody(
        link_name(model, int(model.jnt_bodyid[root])),
        address,
        height,
        tilt,
        tuple(link_name(model, link) for link in feet),
    )


def _settling(body: FreeBody | None, n_settle: int, dt: float, settled: bool) -> Settling:
    """How the start pose settled: a free-floating robot's drop and tilt doing so."""
    return Settling(
        duration_s=n_settle * dt,
        drop_m=float(body.height_m[0] - body.height_m[n_settle]) if body else 0.0,
        tilt_deg=float(abs(body.tilt_deg[n_settle] - body.tilt_deg[0])) if body else 0.0,
        still=settled,
    )


def _joint_links(model: mujoco.MjModel, robot: Robot) -> tuple[str, ...]:
    links = link_of_body(model)
    return tuple(
        link_name(model, int(links[model.joint(joint.mjcf_joint).bodyid[0]]))
        for joint in robot.joints
    )


def _root_pose(qpos: np.ndarray, address: int) -> tuple[np.ndarray, np.ndarray]:
    """Height and tilt from upright of a free joint's body, from its qpos (position and
    quaternion w, x, y, z): the body z axis' vertical component is 1 - 2(x² + y²)."""
    height = qpos[:, address + 2].copy()
    x, y = qpos[:, address + 4], qpos[:, address + 5]
    cos_tilt = np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)
    return height, np.degrees(np.arccos(cos_tilt))
