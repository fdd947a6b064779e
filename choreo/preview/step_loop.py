"""The simulation's step loop: each physics step with the servos' set-points through their law,
recorded; holding the start pose until still; checkpoints of the whole simulator, from which a
later tick list that begins the same way resumes (``Resume``), and at which one that ends the
same way takes the rest of the earlier run once its state is the earlier run's (``Rejoin``)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from choreo.errors import PreviewError
from choreo.plan.ticks import Tick
from choreo.preview.actuator import CommandStream, ServoBank, ServoDrive
from choreo.preview.contact_log import ContactLog
from choreo.preview.rollout import MoveStart
from choreo.robot.types import Robot

INTEGRATION_STATE = mujoco.mjtState.mjSTATE_INTEGRATION  # everything stepping depends on


CHECKPOINT_S = 0.5  # a rollout keeps the whole simulator's state this often (``Resume``)


# Two states this close go on alike (rad and rad/s a joint, m and m/s a free body): the rest of
# the earlier run is taken. Not tighter: a joint left inside its servo's dead band stays where it
# stopped, so a change that nudged it (arm6's wrist, 2e-6 rad after a change at the base) stays
# in every later state and a tighter tolerance never takes the rest.
JOIN_TOLERANCE = 1e-5


STILL_SPEED = 0.01  # m/s and rad/s: every degree of freedom slower than this is still


STILL_FOR_S = 0.05  # ... for this long


MIN_SETTLE_S = 0.02


@dataclass(frozen=True)
class Checkpoint:
    """The simulator as it was at the start of run step ``step`` (before its STARTs): MuJoCo's
    whole integration state, the servos' moves, and how much had been recorded."""

    step: int  # counted from the first step after the settling
    state: np.ndarray
    servos: ServoBank
    drive: ServoDrive
    contacts: int  # entries of the contact log

    def goes_on_as(self, other: Checkpoint, physics: slice, now_s: float) -> bool:
        """Whether the simulator at ``other`` (the same step, at ``now_s``, of another run) goes
        on as at this one for the same ticks: the same servo moves and laws, and joints and
        bodies (``state[physics]``: positions, velocities, actuator states) within
        JOIN_TOLERANCE."""
        apart = np.abs(self.state[physics] - other.state[physics]).max(initial=0.0)
        return (
            bool(apart <= JOIN_TOLERANCE)
            and self.servos.same_as(other.servos, now_s)
            and self.drive.same_as(other.drive, JOIN_TOLERANCE)
        )

    def moved(self, qpos_shift: np.ndarray, physics: slice) -> Checkpoint:
        """This checkpoint with ``qpos_shift`` added to its positions."""
        if not qpos_shift.any():
            return self
        state = self.state.copy()
        state[physics.start : physics.start + len(qpos_shift)] += qpos_shift
        return replace(self, state=state)


@dataclass(frozen=True)
class Resume:
    """What a rollout leaves to simulate faster a tick list that begins as its own did."""

    inputs: tuple  # robot, start angles, settings, posture, props, model digest: the same
    ticks: tuple[Tick, ...]
    settled: bool
    n_settle: int
    record: StepRecord
    contacts: ContactLog
    checkpoints: tuple[Checkpoint, ...]

    def checkpoint_for(
        self, inputs: tuple, ticks: tuple[Tick, ...], dt: float, n_run: int
    ) -> Checkpoint | None:
        """The last checkpoint before the first tick that differs, inside a run of ``n_run``
        steps (None: start afresh)."""
        if inputs != self.inputs:
            return None
        same = 0
        for old, new in zip(self.ticks, ticks):
            if old != new:
                break
            same += 1
        changed = [t[same].start_ms for t in (self.ticks, ticks) if same < len(t)]
        # the first step a START of a changed tick could touch, less one
        first_touched = int(start_step(min(changed) / 1000, dt)) if changed else None
        usable = [
            c
            for c in self.checkpoints
            if c.step < n_run and (first_touched is None or c.step < first_touched)
        ]
        return usable[-1] if usable else None

    def rejoin(
        self, inputs: tuple, ticks: tuple[Tick, ...], dt: float, n_settle: int, n_run: int
    ) -> Rejoin | None:
        """Where a run of ``ticks`` (``n_run`` steps after ``n_settle`` settling) could take the
        rest of this one: from the step after the last START of a tick that differs (None: the
        inputs or lengths differ)."""
        lengths = (n_settle, n_settle + n_run)
        if inputs != self.inputs or lengths != (self.n_settle, self.record.count):
            return None
        same = 0
        for old, new in zip(reversed(self.ticks), reversed(ticks)):
            if old != new:
                break
            same += 1
        changed = [t[len(t) - same - 1].start_ms for t in (self.ticks, ticks) if len(t) > same]
        after = max(changed, default=None)
        from_step = 0 if after is None else int(start_step(after / 1000, dt)) + 1
        return Rejoin(self, from_step, {c.step: c for c in self.checkpoints})


@dataclass(frozen=True)
class Rejoin:
    """An earlier run whose rest a run may take: from step ``from_step`` on both play the same
    ticks, so where the simulator is as it was there (``Checkpoint.goes_on_as``), the earlier
    run's steps, contacts and checkpoints from there on are what simulating on would give."""

    resume: Resume
    from_step: int
    checkpoints: dict[int, Checkpoint]  # the earlier run's, by step


def as_slice(indices: np.ndarray) -> slice | np.ndarray:
    """``indices`` as a slice when they are consecutive and ascending (indexing with it takes a
    view), else as they are."""
    first = int(indices[0]) if len(indices) else 0
    if np.array_equal(indices, np.arange(first, first + len(indices))):
        return slice(first, first + len(indices))
    return indices


def start_step(start_s: float | np.ndarray, dt_s: float) -> np.ndarray:
    """The physics step at which a START at ``start_s`` (one time or an array) happens: the first
    step at or after its time."""
    return np.ceil(np.asarray(start_s) / dt_s - 1e-6).astype(int)


class StepRecord:
    """The recorded signals, one row per physics step."""

    def __init__(self, capacity: int, nq: int, n_joints: int):
        self.qpos = np.empty((capacity, nq))
        self.ctrl = np.empty((capacity, n_joints))
        self.torque = np.empty((capacity, n_joints))
        self.count = 0


class StepLoop:
    """The step loop, kept lean (it runs ~500 times per simulated second)."""

    def __init__(
        self,
        model,
        data,
        index,
        drive: ServoDrive,
        contacts,
        log: StepRecord,
        planar: int | None = None,
    ):
        """``planar``: where a free-floating robot's root x and y are in qpos when nothing in the
        world tells one place on the floor from another (an earlier run that went on alike
        shifted there is taken, shifted)."""
        self.model, self.data, self.index = model, data, index
        self.drive = drive
        self.contacts, self.log = contacts, log
        self.planar = planar
        # where a checkpoint's state holds the positions, velocities and actuator states
        # (mjtState's parts come in the order of their bits: time, qpos, qvel, act first)
        physics = mujoco.mjtState.mjSTATE_QPOS | mujoco.mjtState.mjSTATE_QVEL
        physics |= mujoco.mjtState.mjSTATE_ACT
        time = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME)
        self.physics = slice(time, time + mujoco.mj_stateSize(model, physics))
        # MjData's arrays never move: views of them are taken once, not at every step, and the
        # joints' positions and actuators, when consecutive (as usual), are slices (no copies)
        self._qpos, self._force = data.qpos, data.actuator_force
        self._joint_qpos = as_slice(index.qpos)
        self._actuators = as_slice(index.actuator)
        self._ctrl = data.ctrl[self._actuators] if isinstance(self._actuators, slice) else None

    def steps(self, ctrl_rad: np.ndarray) -> None:
        """A physics step for each row of ``ctrl_rad``, the servos' set-points then, through
        their law (``ServoDrive``: delay, offset, gear play, dead band), each step's aims kept
        within ``ServoDrive.play_edges``. The step is written out here, its names bound once:
        it runs ~500 times per simulated second, and a call or an attribute read per step is a
        few per cent of it."""
        log, data, model, qpos = self.log, self.data, self.model, self._qpos
        first = k = log.count
        log.ctrl[first : first + len(ctrl_rad)] = ctrl_rad
        logged_qpos, logged_torque, force = log.qpos, log.torque, self._force
        joint_qpos, actuators, ctrl_out = self._joint_qpos, self._actuators, self._ctrl
        follow, see, step = self.drive.follow, self.contacts.see, mujoco.mj_step
        for low_rad, high_rad in zip(*self.drive.play_edges(ctrl_rad)):
            ctrl = follow(low_rad, high_rad, qpos[joint_qpos], out=ctrl_out)
            if ctrl_out is None:
                data.ctrl[actuators] = ctrl
            logged_qpos[k] = qpos
            step(model, data)  # its forces and contacts belong to the state at t
            logged_torque[k] = force[actuators]
            if data.ncon:
                see(data, k)
            k += 1
            log.count = k

    def settle(self, hold_rad: np.ndarray, max_steps: int) -> bool:
        """Hold the start pose until every degree of freedom has been still for a while (True)
        or ``max_steps`` have passed (False)."""
        dt = float(self.model.opt.timestep)
        hold = np.asarray(hold_rad, dtype=float)[None]
        return hold_until_still(self.data, dt, lambda: self.steps(hold), max_steps)

    def run(
        self,
        stream: CommandStream,
        servos: ServoBank,
        robot: Robot,
        move_start: MoveStart,
        n: int,
        first: int = 0,
        checkpoint_every: int = 0,
        rejoin: Rejoin | None = None,
    ) -> list[Checkpoint]:
        """The tick stream from step ``first`` (0, or a restored checkpoint's): between two
        STARTs every set-point is a known function of time, so each stretch's controls are
        computed at once. Returns a checkpoint every ``checkpoint_every`` steps (0: none); at
        one where the simulator goes on as ``rejoin``'s run did, the rest is that run's."""
        dt = float(self.model.opt.timestep)
        times = np.arange(n) * dt
        started = np.flatnonzero(stream.started)
        start_steps = start_step(stream.start_s[started], dt)
        marks = range(first, n, checkpoint_every) if checkpoint_every else ()
        boundaries = sorted({first, n, *marks, *[int(b) for b in start_steps if first <= b < n]})
        checkpoints = []
        for begin, end in zip(boundaries[:-1], boundaries[1:]):
            if checkpoint_every and begin % checkpoint_every == 0:
                ours = self._checkpoint(begin, servos)
                checkpoints.append(ours)
                if rejoin is not None and (shift := self._joins(rejoin, ours, dt)) is not None:
                    return checkpoints + self._take_rest(rejoin, ours, shift)
            for tick in started[start_steps == begin]:
                if move_start is MoveStart.POSITION:
                    position_units = robot.to_units(np.degrees(self.data.qpos[self.index.qpos]))
                else:
                    position_units = servos.setpoint_units(times[begin])
                servos.start(stream, tick, times[begin], position_units)
            self.steps(np.radians(robot.to_deg(servos.setpoint_units(times[begin:end]))))
        return checkpoints

    def _checkpoint(self, step: int, servos: ServoBank) -> Checkpoint:
        state = np.empty(mujoco.mj_stateSize(self.model, INTEGRATION_STATE))
        mujoco.mj_getState(self.model, self.data, state, INTEGRATION_STATE)
        return Checkpoint(
            step,
            state,
            copy.deepcopy(servos),
            copy.deepcopy(self.drive),
            len(self.contacts.steps),
        )

    def restore(self, checkpoint: Checkpoint, resume: Resume, n_settle: int) -> ServoBank:
        """The simulator as it was at ``checkpoint`` of ``resume``'s run, with everything
        recorded before it; the servos' moves then (a copy) are returned."""
        mujoco.mj_setState(self.model, self.data, checkpoint.state, INTEGRATION_STATE)
        self.drive = copy.deepcopy(checkpoint.drive)
        count = n_settle + checkpoint.step
        old, log = resume.record, self.log
        log.qpos[:count], log.ctrl[:count] = old.qpos[:count], old.ctrl[:count]
        log.torque[:count] = old.torque[:count]
        log.count = count
        self.contacts.take_from(resume.contacts, checkpoint.contacts)
        return copy.deepcopy(checkpoint.servos)

    def _joins(self, rejoin: Rejoin, ours: Checkpoint, dt: float) -> np.ndarray | None:
        """How far to shift the earlier run's positions (zeros, or a planar root's x and y) to
        go on from ``ours`` as it did from the same step; None: it does not go on alike."""
        theirs = rejoin.checkpoints.get(ours.step) if ours.step >= rejoin.from_step else None
        if theirs is None:
            return None
        shift = np.zeros(self.model.nq)
        if self.planar is not None:
            xy = slice(self.physics.start + self.planar, self.physics.start + self.planar + 2)
            shift[self.planar : self.planar + 2] = ours.state[xy] - theirs.state[xy]
        if not ours.goes_on_as(theirs.moved(shift, self.physics), self.physics, ours.step * dt):
            return None
        return shift

    def _take_rest(self, rejoin: Rejoin, ours: Checkpoint, shift: np.ndarray) -> list[Checkpoint]:
        """What ``rejoin``'s run recorded from ``ours``'s step (going on alike, its positions
        shifted by ``shift``) to its end, as this run's; its later checkpoints are returned
        (shifted too, counting this log's contacts)."""
        resume, theirs = rejoin.resume, rejoin.checkpoints[ours.step]
        begin, end = resume.n_settle + ours.step, resume.record.count
        old, log = resume.record, self.log
        log.qpos[begin:end] = old.qpos[begin:end] + shift
        log.ctrl[begin:end], log.torque[begin:end] = old.ctrl[begin:end], old.torque[begin:end]
        log.count = end
        self.contacts.take_rest(resume.contacts, theirs.contacts)
        more = ours.contacts - theirs.contacts
        return [
            replace(c.moved(shift, self.physics), contacts=c.contacts + more)
            for c in resume.checkpoints
            if c.step > ours.step
        ]


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
