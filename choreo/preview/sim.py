"""The MuJoCo rollout of a tick list: servos in, recorded behaviour out.

Each physics step, every servo's own linear interpolation (``actuator.ServoBank``) gives its
set-point; the model's position actuators, made into the servo model (``preview/model.py``), turn
it into torque, so lag and saturation look like the hardware. Everything the checks and the
renderer need is recorded in a ``Rollout``; nothing here judges it, and nothing here knows the
motion the ticks came from (``pipeline.py`` measures the rollout against it).
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from enum import Enum

import mujoco
import numpy as np

from choreo.core.arguments import NON_NEGATIVE, Range, check_member, check_number
from choreo.errors import PreviewError
from choreo.motion.scene import Prop, StartPosture
from choreo.plan.ticks import Tick
from choreo.preview.actuator import (
    ActuatorParams,
    CommandStream,
    ServoBank,
    ServoDrive,
    actuator_params,
    commanded_path_units,
    max_speed_units_s,
)
from choreo.preview.model import (
    FLOOR_CONTACT,
    FOOT_CONTACT,
    GROUND_CONTACT,
    HELD_CONTACT,
    NEIGHBOUR_CONTACT,
    NO_CONTACT,
    SELF_CONTACT,
    apply_servo_models,
    contact_kinds,
    free_joint,
    free_prop_joints,
    geom_labels,
    index_joints,
    link_name,
    link_of_body,
    load_model,
)
from choreo.preview.start import foot_links, start_state
from choreo.robot.types import Robot

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


INTEGRATION_STATE = mujoco.mjtState.mjSTATE_INTEGRATION  # everything stepping depends on
CHECKPOINT_S = 1.0  # a rollout keeps the whole simulator's state this often (``Resume``)
STILL_SPEED = 0.01  # m/s and rad/s: every degree of freedom slower than this is still
STILL_FOR_S = 0.05  # ... for this long
MIN_SETTLE_S = 0.02

CONTACT_NAMES = {
    SELF_CONTACT: "self",
    FLOOR_CONTACT: "floor",
    NEIGHBOUR_CONTACT: "neighbour",
    GROUND_CONTACT: "ground",
    FOOT_CONTACT: "foot",
    HELD_CONTACT: "held",
}


@dataclass(frozen=True)
class ContactPair:
    """Two things touching that may not: ``kind`` is "self" (two links that are not parent and
    child), "neighbour" (a parent and child link MuJoCo lets collide), "floor" (a fixed robot's
    link on a world geom, named ``body_b``), "ground" (a free-floating robot's link other than
    a foot on the floor or a fixed prop, named ``body_b``), "foot" (a foot there), or "held" (a
    link on a free prop: expected, recorded to say what a straining servo pushes on)."""

    kind: str
    body_a: str
    body_b: str


@dataclass(frozen=True)
class Settling:
    """The start pose held until still, before the approach: how far the body dropped and
    tilted doing so (a free-floating robot's root body; zeros for a fixed robot)."""

    duration_s: float
    drop_m: float
    tilt_deg: float
    still: bool  # False: still moving after SimSettings.max_settle_s


@dataclass(frozen=True)
class Contacts:
    """The touches worth reporting, one entry per physics step and pair touching: the step, the
    pair (an index into ``pairs``) and how deep."""

    pairs: tuple[ContactPair, ...]
    step: np.ndarray  # (k,) step index of each recorded contact
    pair: np.ndarray  # (k,) index into pairs
    depth_m: np.ndarray  # (k,) penetration depth

    def mask(self, pair_index: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Per step of ``steps``: whether the pair touches, and how deep (m)."""
        mine = self.pair == pair_index
        touching = np.zeros(steps, dtype=bool)
        touching[self.step[mine]] = True
        depth = np.zeros(steps)
        np.maximum.at(depth, self.step[mine], self.depth_m[mine])
        return touching, depth

    def since(self, k: int) -> Contacts:
        """The contacts from step ``k`` on, their steps counted from there."""
        keep = self.step >= k
        return Contacts(self.pairs, self.step[keep] - k, self.pair[keep], self.depth_m[keep])


@dataclass(frozen=True)
class FreeBody:
    """A free-floating robot's root body (the one carrying the free joint), step by step."""

    name: str
    qpos_address: int  # where its position and quaternion start in qpos
    height_m: np.ndarray  # (n,)
    tilt_deg: np.ndarray  # (n,) angle between its z axis and the vertical
    feet: tuple[str, ...] = ()  # the robot's foot links: what may touch the ground

    def since(self, k: int) -> FreeBody:
        return replace(self, height_m=self.height_m[k:], tilt_deg=self.tilt_deg[k:])


@dataclass(frozen=True)
class Rollout:
    """What the simulation recorded, sampled at every physics step. Times count from the
    motion's start: negative ones are the settling, then the approach (from
    ``approach_start_s``)."""

    robot: Robot
    times_s: np.ndarray  # (n,)
    position_deg: np.ndarray  # (n, joints) the joints' real angles
    setpoint_deg: np.ndarray  # (n, joints) where each servo's own interpolation is
    command_deg: np.ndarray  # (n, joints) the path the ticks ask for (no load, no lag)
    torque_nm: np.ndarray  # (n, joints) actuator torque
    qpos: np.ndarray  # (n, nq) full MuJoCo state, for rendering
    actuators: tuple[ActuatorParams, ...]
    contacts: Contacts
    commands_end_s: float  # when the last commanded move is due to finish
    keyframe_times_s: tuple[float, ...] = ()
    body: FreeBody | None = None  # a free-floating robot's root body; None: fixed to the world
    approach_start_s: float = 0.0  # <= 0: when the approach into the first pose begins
    settling: Settling | None = None
    posture: StartPosture = StartPosture.STANDING
    props: tuple[Prop, ...] = ()
    move_start: MoveStart = MoveStart.SETPOINT
    joint_links: tuple[str, ...] = ()  # the link each joint moves (robot joint order)
    # each free prop's name and where its position and quaternion start in qpos
    prop_qpos_addresses: tuple[tuple[str, int], ...] = ()
    resume: Resume | None = None  # to simulate a tick list that begins the same way faster

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def start_step(self) -> int:
        """The first step of the approach: the robot at rest in its start pose."""
        return int(np.searchsorted(self.times_s, self.approach_start_s - 1e-9))

    @property
    def stall_torque_nm(self) -> np.ndarray:
        return np.array([a.stall_torque_nm for a in self.actuators])

    def since_start(self) -> Rollout:
        """The rollout from the start (the robot at rest before the approach): what the checks
        judge; the settling before it is the simulation finding its feet, reported apart."""
        k = self.start_step
        return replace(
            self,
            times_s=self.times_s[k:],
            position_deg=self.position_deg[k:],
            setpoint_deg=self.setpoint_deg[k:],
            command_deg=self.command_deg[k:],
            torque_nm=self.torque_nm[k:],
            qpos=self.qpos[k:],
            contacts=self.contacts.since(k),
            body=None if self.body is None else self.body.since(k),
        )

    def phase(self, t: float) -> str:
        """ "settling", "approach" or "motion" at time ``t``."""
        if t < self.approach_start_s - 1e-9:
            return "settling"
        return "approach" if t < -1e-9 else "motion"


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
    checkpoint before that tick; the result is the same, bit for bit."""
    n_joints = len(robot.joints)
    start_deg = np.asarray(initial_deg, dtype=float)
    if start_deg.shape != (n_joints,):
        raise ValueError(
            f"initial_deg needs {n_joints} angles (robot joint order), got shape {start_deg.shape}"
        )
    stream = CommandStream.from_ticks(ticks, n_joints)
    params = actuator_params(robot, settings.actuator_overrides)

    model = load_model(robot, props)
    index = index_joints(model, robot)
    apply_servo_models(model, index, params, robot)
    root = free_joint(model)
    feet: tuple[int, ...] = ()
    if root is not None and "home" in robot.poses:
        feet = foot_links(model, index, robot.pose_vector("home"))
    data = start_state(model, index, start_deg, posture)
    dt = float(model.opt.timestep)
    drive = ServoDrive(params, dt, np.radians(start_deg))

    initial_units = robot.to_units(start_deg)
    servos = ServoBank(initial_units, max_speed_units_s(params))
    contacts = _ContactLog(model, settings.min_contact_depth_m, feet)
    max_settle = round(settings.max_settle_s / dt)
    n_run = int(math.floor((stream.end_s + settings.tail_s) / dt + 1e-9)) + 1
    record = _Log(max_settle + n_run, model.nq, n_joints)
    loop = _Loop(model, data, index, drive, contacts, record)
    inputs = (robot, tuple(start_deg), settings, posture, tuple(props))
    checkpoint = None if resume is None else resume.checkpoint_for(inputs, tuple(ticks), dt, n_run)
    if resume is not None and checkpoint is not None:
        settled, n_settle = resume.settled, resume.n_settle
        servos = loop.restore(checkpoint, resume, n_settle)
        first = checkpoint.step
    else:
        settled = loop.settle(np.radians(start_deg), max_settle)
        n_settle, first = record.count, 0
    checkpoints = loop.run(
        stream, servos, robot, settings.move_start, n_run, first, round(CHECKPOINT_S / dt)
    )
    check_stable(model, data)
    if checkpoint is not None:
        checkpoints = [c for c in resume.checkpoints if c.step < first] + checkpoints  # type: ignore[union-attr]

    n = record.count
    stream_times = (np.arange(n) - n_settle) * dt
    body = None
    if root is not None:
        address = int(model.jnt_qposadr[root])
        height, tilt = _root_pose(record.qpos[:n], address)
        body = FreeBody(
            link_name(model, int(model.jnt_bodyid[root])),
            address,
            height,
            tilt,
            tuple(link_name(model, link) for link in feet),
        )
    settling = Settling(
        duration_s=n_settle * dt,
        drop_m=float(body.height_m[0] - body.height_m[n_settle]) if body else 0.0,
        tilt_deg=float(abs(body.tilt_deg[n_settle] - body.tilt_deg[0])) if body else 0.0,
        still=settled,
    )
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
        settling=settling,
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


def _joint_links(model: mujoco.MjModel, robot: Robot) -> tuple[str, ...]:
    links = link_of_body(model)
    return tuple(
        link_name(model, int(links[model.joint(joint.mjcf_joint).bodyid[0]]))
        for joint in robot.joints
    )


@dataclass(frozen=True)
class _Checkpoint:
    """The simulator as it was at the start of run step ``step`` (before its STARTs): MuJoCo's
    whole integration state, the servos' moves, and how much had been recorded."""

    step: int  # counted from the first step after the settling
    state: np.ndarray
    servos: ServoBank
    drive: ServoDrive
    contacts: int  # entries of the contact log
    pairs: int  # contact pairs named


@dataclass(frozen=True)
class Resume:
    """What a rollout leaves to simulate faster a tick list that begins as its own did."""

    inputs: tuple  # robot, start angles, settings, posture, props: must be the same
    ticks: tuple[Tick, ...]
    settled: bool
    n_settle: int
    record: _Log
    contacts: _ContactLog
    checkpoints: tuple[_Checkpoint, ...]

    def checkpoint_for(
        self, inputs: tuple, ticks: tuple[Tick, ...], dt: float, n_run: int
    ) -> _Checkpoint | None:
        """The last checkpoint before the first tick that differs, inside a run of ``n_run``
        steps (None: start afresh)."""
        if inputs != self.inputs:
            return None
        same = 0
        for old, new in zip(self.ticks, ticks):
            if old != new:
                break
            same += 1
        if same == len(self.ticks) == len(ticks):
            changed_s = math.inf
        else:
            changed = [t[same].start_ms for t in (self.ticks, ticks) if same < len(t)]
            changed_s = min(changed) / 1000
        # the first step a START at changed_s could touch (as _Loop.run rounds it), less one
        first_touched = math.ceil(changed_s / dt - 1e-6) if math.isfinite(changed_s) else None
        usable = [
            c
            for c in self.checkpoints
            if c.step < n_run and (first_touched is None or c.step < first_touched)
        ]
        return usable[-1] if usable else None


class _Log:
    """The recorded signals, one row per physics step."""

    def __init__(self, capacity: int, nq: int, n_joints: int):
        self.qpos = np.empty((capacity, nq))
        self.ctrl = np.empty((capacity, n_joints))
        self.torque = np.empty((capacity, n_joints))
        self.count = 0


class _Loop:
    """The step loop, kept lean (it runs ~500 times per simulated second)."""

    def __init__(self, model, data, index, drive: ServoDrive, contacts, log: _Log):
        self.model, self.data, self.index = model, data, index
        self.drive = drive
        self.contacts, self.log = contacts, log

    def step(self, ctrl_rad: np.ndarray) -> None:
        """One physics step with the servos' set-points at ``ctrl_rad``, through their law
        (``ServoDrive``: delay, offset, gear play, dead band)."""
        data, log, k = self.data, self.log, self.log.count
        data.ctrl[self.index.actuator] = self.drive.ctrl(ctrl_rad, data.qpos[self.index.qpos])
        log.ctrl[k] = ctrl_rad
        log.qpos[k] = data.qpos
        mujoco.mj_step(self.model, data)  # its forces and contacts belong to the state at t
        log.torque[k] = data.actuator_force[self.index.actuator]
        if data.ncon:
            self.contacts.see(data, k)
        log.count = k + 1

    def settle(self, hold_rad: np.ndarray, max_steps: int) -> bool:
        """Hold the start pose until every degree of freedom has been still for a while (True)
        or ``max_steps`` have passed (False)."""
        dt = float(self.model.opt.timestep)
        return hold_until_still(self.data, dt, lambda: self.step(hold_rad), max_steps)

    def run(
        self,
        stream: CommandStream,
        servos: ServoBank,
        robot: Robot,
        move_start: MoveStart,
        n: int,
        first: int = 0,
        checkpoint_every: int = 0,
    ) -> list[_Checkpoint]:
        """The tick stream from step ``first`` (0, or a restored checkpoint's): between two
        STARTs every set-point is a known function of time, so each stretch's controls are
        computed at once. Returns a checkpoint every ``checkpoint_every`` steps (0: none)."""
        dt = float(self.model.opt.timestep)
        times = np.arange(n) * dt
        started = np.flatnonzero(stream.started)
        # the step at which each START happens: the first step at or after its time
        start_steps = np.ceil(stream.start_s[started] / dt - 1e-6).astype(int)
        marks = range(first, n, checkpoint_every) if checkpoint_every else ()
        boundaries = sorted({first, n, *marks, *[int(b) for b in start_steps if first <= b < n]})
        checkpoints = []
        for begin, end in zip(boundaries[:-1], boundaries[1:]):
            if checkpoint_every and begin % checkpoint_every == 0:
                checkpoints.append(self._checkpoint(begin, servos))
            for tick in started[start_steps == begin]:
                if move_start is MoveStart.POSITION:
                    position_units = robot.to_units(np.degrees(self.data.qpos[self.index.qpos]))
                else:
                    position_units = servos.setpoint_units(times[begin])
                servos.start(stream, tick, times[begin], position_units)
            ctrl = np.radians(robot.to_deg(servos.setpoint_units(times[begin:end])))
            for row in ctrl:
                self.step(row)
        return checkpoints

    def _checkpoint(self, step: int, servos: ServoBank) -> _Checkpoint:
        state = np.empty(mujoco.mj_stateSize(self.model, INTEGRATION_STATE))
        mujoco.mj_getState(self.model, self.data, state, INTEGRATION_STATE)
        return _Checkpoint(
            step,
            state,
            copy.deepcopy(servos),
            copy.deepcopy(self.drive),
            len(self.contacts.steps),
            self.contacts.named,
        )

    def restore(self, checkpoint: _Checkpoint, resume: Resume, n_settle: int) -> ServoBank:
        """The simulator as it was at ``checkpoint`` of ``resume``'s run, with everything
        recorded before it; the servos' moves then (a copy) are returned."""
        mujoco.mj_setState(self.model, self.data, checkpoint.state, INTEGRATION_STATE)
        self.drive = copy.deepcopy(checkpoint.drive)
        count = n_settle + checkpoint.step
        old, log = resume.record, self.log
        log.qpos[:count], log.ctrl[:count] = old.qpos[:count], old.ctrl[:count]
        log.torque[:count] = old.torque[:count]
        log.count = count
        self.contacts.take_from(resume.contacts, checkpoint.contacts, checkpoint.pairs)
        return copy.deepcopy(checkpoint.servos)


def hold_until_still(
    data: mujoco.MjData, dt_s: float, step: Callable[[], None], max_steps: int
) -> bool:
    """Call ``step`` (one physics step holding a pose) until every degree of freedom has been
    still for a while (True) or ``max_steps`` have passed (False)."""
    min_steps, still_steps = round(MIN_SETTLE_S / dt_s), round(STILL_FOR_S / dt_s)
    still_since = 0
    for k in range(max_steps):
        step()
        if np.abs(data.qvel).max(initial=0.0) >= STILL_SPEED:
            still_since = k + 1
        elif k + 1 >= max(min_steps, still_since + still_steps):
            return True
    return max_steps == 0


def check_stable(model: mujoco.MjModel, data: mujoco.MjData) -> None:
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

    def __init__(self, model: mujoco.MjModel, min_depth_m: float, feet: Sequence[int] = ()):
        self._kinds = contact_kinds(model, free_floating=free_joint(model) is not None, feet=feet)
        self._labels = geom_labels(model)
        self._on_world = model.geom_bodyid == 0
        self._min_depth_m = min_depth_m
        self._last_pairs = b""
        # indices into the current contact list, with the pair each touch belongs to
        self._watched: list[tuple[int, tuple[int, str, str]]] = []
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
            watched = np.flatnonzero(self._kinds[geoms[:, 0], geoms[:, 1]] != NO_CONTACT)
            self._watched = [(int(i), self._pair_key(*geoms[i])) for i in watched]
        if not self._watched:
            return
        depths = -contact.dist[: data.ncon]
        for i, key in self._watched:
            if depths[i] > self._min_depth_m:
                self.steps.append(step)
                self.pair_index.append(self._pair_ids.setdefault(key, len(self._pair_ids)))
                self.depths_m.append(float(depths[i]))

    def _pair_key(self, g1: int, g2: int) -> tuple[int, str, str]:
        """The pair's kind and names (the world's or a prop's second, else sorted), which are
        numbered as they are first recorded."""
        kind = int(self._kinds[g1, g2])
        a, b = self._labels[g1], self._labels[g2]
        if kind in (FLOOR_CONTACT, GROUND_CONTACT, FOOT_CONTACT):
            names = (b, a) if self._on_world[g1] else (a, b)
        else:
            names = (a, b) if a <= b else (b, a)  # sorted
        return (kind, *names)

    @property
    def named(self) -> int:
        return len(self._pair_ids)

    def take_from(self, other: _ContactLog, entries: int, pairs: int) -> None:
        """``other``'s first ``entries`` contacts and ``pairs`` named pairs, as this log's."""
        self.steps = other.steps[:entries]
        self.pair_index = other.pair_index[:entries]
        self.depths_m = other.depths_m[:entries]
        self._pair_ids = dict(list(other._pair_ids.items())[:pairs])

    def recorded(self) -> Contacts:
        ordered = sorted(self._pair_ids, key=self._pair_ids.__getitem__)
        return Contacts(
            tuple(ContactPair(CONTACT_NAMES[kind], a, b) for kind, a, b in ordered),
            np.array(self.steps, dtype=int),
            np.array(self.pair_index, dtype=int),
            np.array(self.depths_m, dtype=float),
        )
