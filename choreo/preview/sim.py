"""The MuJoCo rollout of a tick list: servos in, recorded behaviour out.

Each physics step, every servo's own linear interpolation (``servo.ServoBank``) gives its
set-point; the model's position actuators, made into the servo model (``model.py``), turn it into
torque, so lag and saturation look like the hardware. Everything the checks and the renderer need
is recorded in a ``Rollout``; nothing here judges it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

import mujoco
import numpy as np

from ..errors import PreviewError
from ..robot import Robot
from ..segments import Tick
from .model import (
    FLOOR_CONTACT,
    NO_CONTACT,
    SELF_CONTACT,
    apply_servo_models,
    contact_kinds,
    free_joint,
    geom_labels,
    index_joints,
    link_name,
    load_model,
    start_state,
)
from .servo import (
    ActuatorParams,
    CommandStream,
    ServoBank,
    UnitsToDeg,
    actuator_params,
    commanded_path_units,
    max_speed_units_s,
)

log = logging.getLogger(__name__)


class MoveStart(str, Enum):
    """Where a servo's new linear move starts (undocumented for the real servo).

    SETPOINT: where its own interpolation is, so a servo lagging under load keeps pulling towards
    its plan (what a position loop with integral action amounts to). POSITION: where its shaft
    measurably is, so each START forgets the lag; with a proportional-only servo model a loaded
    joint then drops a little at every START, and a re-run preset from a sagged position creeps
    back over the preset's whole time: the pessimistic assumption.
    """

    SETPOINT = "setpoint"
    POSITION = "position"


@dataclass(frozen=True)
class SimSettings:
    settle_s: float = 0.5  # servos hold the first pose this long before the motion starts
    move_start: MoveStart = MoveStart.SETPOINT
    tail_s: float = 0.5  # keep simulating after the last move is due to finish
    min_contact_depth_m: float = 0.0  # touches this shallow or shallower are not recorded
    # joint name -> {ActuatorParams field: value}: the robot's measured servo, if it has one
    actuator_overrides: Mapping[str, Mapping[str, float]] | None = None

    def __post_init__(self) -> None:
        for name in ("settle_s", "tail_s", "min_contact_depth_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value!r}")


@dataclass(frozen=True)
class ContactPair:
    """Two things touching that should not: ``kind`` is "self" (two links that are not parent
    and child) or "floor" (a fixed robot's link on a world geom, named ``body_b``)."""

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
    root_qpos_address: int | None = None  # where its position and quaternion start in qpos

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def stall_torque_nm(self) -> np.ndarray:
        return np.array([a.stall_torque_nm for a in self.actuators])


def simulate(
    robot: Robot,
    ticks: Sequence[Tick],
    initial_deg: Sequence[float],
    keyframe_times_s: Sequence[float] = (),
    settings: SimSettings = SimSettings(),
) -> Rollout:
    """Play ``ticks`` (what the bus will send) to the simulated robot, starting at rest at
    ``initial_deg`` (robot joint order; the player approaches the first pose before starting)."""
    n_joints = len(robot.joints)
    initial_deg = np.asarray(initial_deg, dtype=float)
    if initial_deg.shape != (n_joints,):
        raise ValueError(
            f"initial_deg needs {n_joints} angles (robot joint order), "
            f"got shape {initial_deg.shape}"
        )
    stream = CommandStream.from_ticks(ticks, n_joints)
    params = actuator_params(robot, settings.actuator_overrides)
    to_deg = UnitsToDeg.for_joints(robot.joints)

    model = load_model(robot)
    index = index_joints(model, robot)
    apply_servo_models(model, index, params, to_deg)
    data = start_state(model, index, initial_deg)
    dt = float(model.opt.timestep)
    for _ in range(round(settings.settle_s / dt)):  # ctrl holds the first pose
        mujoco.mj_step(model, data)

    n = int(math.floor((stream.end_s + settings.tail_s) / dt + 1e-9)) + 1
    initial_units = to_deg.units(initial_deg)
    servos = ServoBank(initial_units, max_speed_units_s(params))
    contacts = _ContactLog(model, settings.min_contact_depth_m)
    qpos_log = np.empty((n, model.nq))
    ctrl_log = np.empty((n, n_joints))
    torque_log = np.empty((n, n_joints))
    _run(
        model,
        data,
        index,
        stream,
        servos,
        to_deg,
        settings.move_start,
        n,
        qpos_log,
        ctrl_log,
        torque_log,
        contacts,
    )
    _check_stable(model, data)

    times = np.arange(n) * dt
    root = free_joint(model)
    height = tilt = None
    if root is not None:
        height, tilt = _root_pose(qpos_log, model.jnt_qposadr[root])
    return Rollout(
        robot=robot,
        times_s=times,
        position_deg=np.degrees(qpos_log[:, index.qpos]),
        setpoint_deg=np.degrees(ctrl_log),
        command_deg=to_deg.deg(commanded_path_units(stream, initial_units, times)),
        torque_nm=torque_log,
        qpos=qpos_log,
        actuators=params,
        contact_pairs=contacts.pairs(),
        contact_step=np.array(contacts.steps, dtype=int),
        contact_pair=np.array(contacts.pair_index, dtype=int),
        contact_depth_m=np.array(contacts.depths_m, dtype=float),
        commands_end_s=stream.end_s,
        keyframe_times_s=tuple(float(t) for t in keyframe_times_s),
        root_body=link_name(model, int(model.jnt_bodyid[root])) if root is not None else None,
        root_height_m=height,
        root_tilt_deg=tilt,
        root_qpos_address=int(model.jnt_qposadr[root]) if root is not None else None,
    )


def _run(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    index,
    stream: CommandStream,
    servos: ServoBank,
    to_deg: UnitsToDeg,
    move_start: MoveStart,
    n: int,
    qpos_log: np.ndarray,
    ctrl_log: np.ndarray,
    torque_log: np.ndarray,
    contacts: _ContactLog,
) -> None:
    """The step loop, kept lean (it runs ~500 times per simulated second): between two STARTs
    every set-point is a known function of time, so each stretch's controls are computed at
    once and the loop only steps and records."""
    dt = float(model.opt.timestep)
    times = np.arange(n) * dt
    ctrl_scale, ctrl_offset = np.radians(to_deg.scale), np.radians(to_deg.offset)
    started = np.flatnonzero(stream.started)
    # the step at which each START happens: the first step at or after its time
    start_steps = np.ceil(stream.start_s[started] / dt - 1e-6).astype(int)
    boundaries = sorted({0, n, *[int(b) for b in start_steps if b < n]})
    actuators = index.actuator
    for begin, end in zip(boundaries[:-1], boundaries[1:]):
        for tick in started[start_steps == begin]:
            if move_start is MoveStart.POSITION:
                position_units = to_deg.units(np.degrees(data.qpos[index.qpos]))
            else:
                position_units = servos.setpoint_units(times[begin])
            servos.start(stream, tick, times[begin], position_units)
        ctrl = servos.setpoint_units(times[begin:end]) * ctrl_scale + ctrl_offset
        ctrl_log[begin:end] = ctrl
        for step in range(begin, end):
            data.ctrl[actuators] = ctrl[step - begin]
            qpos_log[step] = data.qpos
            mujoco.mj_step(model, data)  # its forces and contacts belong to the state at t
            torque_log[step] = data.actuator_force[actuators]
            if data.ncon:
                contacts.see(data, step)


def _check_stable(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """MuJoCo resets the state when accelerations blow up; a rollout after that means nothing."""
    warning = data.warning[mujoco.mjtWarning.mjWARN_BADQACC]
    if warning.number:
        joint = (
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.dof_jntid[warning.lastinfo])
            or "a joint"
        )
        raise PreviewError(
            f"the simulation became unstable ({warning.number} bad accelerations, "
            f"last at {joint}): check the MJCF's masses, inertias and timestep, and "
            f"any actuator overrides"
        )


def _root_pose(qpos: np.ndarray, address: int) -> tuple[np.ndarray, np.ndarray]:
    """Height and tilt from upright of a free joint's body, from its qpos (position and
    quaternion w, x, y, z): the body z axis' vertical component is 1 - 2(x² + y²)."""
    height = qpos[:, address + 2].copy()
    x, y = qpos[:, address + 4], qpos[:, address + 5]
    cos_tilt = np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)
    return height, np.degrees(np.arccos(cos_tilt))


class _ContactLog:
    """The contacts worth reporting, step by step. Most steps repeat the previous step's contact
    pairs (feet on the floor), so pairs are only classified when they change."""

    def __init__(self, model: mujoco.MjModel, min_depth_m: float):
        self._kinds = contact_kinds(model, free_floating=free_joint(model) is not None)
        self._labels = geom_labels(model)
        self._on_world = model.geom_bodyid == 0
        self._min_depth_m = min_depth_m
        self._last_pairs = b""
        self._watched = np.empty(0, dtype=int)  # indices into the current contact list
        self._pair_ids: dict[tuple[int, str, str], int] = {}
        self.steps: list[int] = []
        self.pair_index: list[int] = []
        self.depths_m: list[float] = []

    def see(self, data: mujoco.MjData, step: int) -> None:
        contact = data.contact
        geoms = contact.geom[: data.ncon]
        pairs = geoms.tobytes()
        if pairs != self._last_pairs:
            self._last_pairs = pairs
            self._watched = np.flatnonzero(self._kinds[geoms[:, 0], geoms[:, 1]] != NO_CONTACT)
        if not len(self._watched):
            return
        depths = -contact.dist[: data.ncon]
        for i in self._watched:
            if depths[i] > self._min_depth_m:
                self.steps.append(step)
                self.pair_index.append(self._pair_id(int(geoms[i, 0]), int(geoms[i, 1])))
                self.depths_m.append(float(depths[i]))

    def _pair_id(self, g1: int, g2: int) -> int:
        kind = int(self._kinds[g1, g2])
        a, b = self._labels[g1], self._labels[g2]
        if kind == FLOOR_CONTACT:
            names = (b, a) if self._on_world[g1] else (a, b)
        else:
            names = tuple(sorted((a, b)))
        return self._pair_ids.setdefault((kind, *names), len(self._pair_ids))

    def pairs(self) -> tuple[ContactPair, ...]:
        ordered = sorted(self._pair_ids, key=self._pair_ids.get)
        return tuple(
            ContactPair("self" if kind == SELF_CONTACT else "floor", a, b) for kind, a, b in ordered
        )
