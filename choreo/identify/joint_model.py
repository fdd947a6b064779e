"""One servo on its joint, simulated for many candidate figures at once: what the fit compares
with what was measured.

The same law as the preview's (``preview/actuator.py``: the servo's own linear moves capped at
its speed, its response delay, the horn's offset, gear play, dead band, a position gain up to the
stall torque, back-EMF damping, dry friction that holds as MuJoCo's does), on the joint alone:
its inertia and the gravity torque on it come from the robot's model with every other joint
held (``JointLoad``). Each physics step works on arrays with one entry per candidate, so a whole
generation of the search costs about what one candidate does.

Its neighbours in the chain yield under the torque the joint puts out: where they were read
during the moves, they are simulated as servos holding, moved by the joint, their slow motion
from their reads (``neighbours``); the joint's inertia is then lightened by theirs, and their
torque pushes it, the same for every candidate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from choreo.identify.compiled import clip as _clip
from choreo.identify.compiled import interp as _interp
from choreo.identify.neighbours import NeighbourPush, NeighbourReads, neighbour_push
from choreo.preview.joint_load import JointLoad

# the joint model's step, 1.5 of the preview's. On a joint whose load is mostly its servo's own
# armature (arm6's base, wrist_pitch, a coxa), 6 ms strayed 0.04-0.15° on average from a 1 ms
# simulation over a quick step, as much as the fit's whole error, and the wrist_pitch's gain came
# out up to 21 % high on hidden truths (4/5 within 15 % at 3 ms, 3/5 at 6 ms); 3 ms halves the
# straying (the search takes it for its last third only, `fit.py`)
FIT_STEP_S = 0.003
# the step of the search's first two thirds, which find the valley: 6 ms costs half as much
COARSE_STEP_S = 0.006

# the figures fitted, in this order (offset only where a torque-off drop was allowed)
FIGURES = (
    "deadband_deg",
    "backlash_deg",
    "no_load_speed_deg_s",
    "kp_nm_rad",
    "stall_torque_nm",
    "friction_nm",
    "response_delay_s",
    "offset_deg",
)


@dataclass(frozen=True)
class SentMove:
    """A move sent to the servo: when (s, from the recording's start), where to (degrees, the
    servo's frame: what it reads) and in what time (s)."""

    at_s: float
    target_deg: float
    time_s: float


@dataclass(frozen=True)
class Unload:
    """The servo's torque switched off at ``at_s`` (a drop), until the next move."""

    at_s: float


@dataclass(frozen=True)
class SupplyReads:
    """The servo's supply reads during the moves: midpoint times (s) and volts."""

    read_s: np.ndarray
    volts: np.ndarray


@dataclass(frozen=True)
class Trial:
    """What was sent and read over one stretch of test moves: the commands, the position reads
    (midpoint times and degrees), where the servo aimed and stood at the start, its
    neighbours' reads (none: they are taken as rigid) and its supply reads."""

    commands: tuple[SentMove | Unload, ...]
    read_s: np.ndarray
    read_deg: np.ndarray
    start_setpoint_deg: float
    neighbours: tuple[NeighbourReads, ...] = ()
    supply: SupplyReads | None = None

    @property
    def duration_s(self) -> float:
        return float(self.read_s[-1]) if len(self.read_s) else 0.0


def simulate(
    trial: Trial,
    load: JointLoad,
    figures: dict[str, np.ndarray],
    dt_s: float = FIT_STEP_S,
    *,
    supply_sag_per_nm: float = 0.0,
    pushed: NeighbourPush | None = None,
) -> np.ndarray:
    """Where the servo would read at ``trial.read_s``, for each candidate: ``figures`` maps every
    name of :data:`FIGURES` to an array of candidates (shape (k,)); returns (reads, k) degrees.
    ``supply_sag_per_nm``: the share of its supply (so of its torque and gain) the servo loses
    per N·m it pushes (:func:`supply_sag`). ``pushed``: what the neighbours do to it
    (:func:`push_of_neighbours` for this trial and step: the same for every candidate, so a fit
    works it out once), else worked out here.

    The set-points (the servo's own moves, late by its delay) are worked out for every step at
    once; only what depends on where the joint is (gear play, dead band, torque, motion) is
    stepped."""
    times, positions, _ = _run(trial, load, figures, dt_s, supply_sag_per_nm, pushed)
    return np.degrees(
        np.column_stack(
            [np.interp(trial.read_s, times, positions[:, c]) for c in range(positions.shape[1])]
        )
    )


def supply_sag(
    trial: Trial,
    load: JointLoad,
    figures: dict[str, float],
    pushed: NeighbourPush | None = None,
) -> float:
    """The share of its supply the servo loses per N·m it pushes, from its supply reads: the
    line through them against how hard the servo with ``figures`` would have pushed then. The
    supply sags by its resistance times the current the servos draw (a servo's in proportion
    to its torque), and a servo's torque and gain sag with it, not its back-EMF damping: a
    model that leaves it out takes the servo for slower than it is (arm6: 4-8 %). Per N·m,
    not per share of the stall torque: most reads are of holds against gravity, whose torque
    the figures do not change. 0 without reads that tell (too few, or all at one load).
    ``pushed``: what the neighbours do at ``COARSE_STEP_S``, as for :func:`simulate`."""
    reads = trial.supply
    if reads is None or len(reads.read_s) < 3:
        return 0.0
    one = {name: np.array([value]) for name, value in figures.items()}
    times, _, pushing = _run(trial, load, one, COARSE_STEP_S, 0.0, pushed, record=True)
    torque = np.interp(reads.read_s, times, pushing[:, 0])
    if np.ptp(torque) < 0.05 * figures["stall_torque_nm"]:
        return 0.0
    slope, volts_unloaded = np.polyfit(torque, reads.volts, 1)
    return max(0.0, float(-slope / volts_unloaded)) if volts_unloaded > 0 else 0.0


def _run(
    trial: Trial,
    load: JointLoad,
    figures: dict[str, np.ndarray],
    dt_s: float,
    supply_sag_per_nm: float,
    pushed: NeighbourPush | None,
    record: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steps' end times, each candidate's angle after each step (n_steps, k) radians and,
    if ``record``, how hard its servo pushed in each (N·m; else none)."""
    k = len(figures["kp_nm_rad"])
    n_steps = int(np.ceil(trial.duration_s / dt_s)) + 2
    wanted, loaded, reloads = _aims(trial, figures, n_steps, dt_s)
    times = np.arange(1, n_steps + 1) * dt_s  # each position is the state after its step
    neighbours = pushed or push_of_neighbours(trial, load, dt_s)
    half_play = np.radians(figures["backlash_deg"]) / 2
    stall = figures["stall_torque_nm"]
    damping = stall / np.radians(figures["no_load_speed_deg_s"])  # back-EMF, as the preview has it
    offset = np.radians(figures["offset_deg"])
    # its inertia with the neighbours free to move: it changes with the joint's angle by under
    # 2 % over a trial (arm6, tonypi), so one figure, which keeps the steps below scalar
    inertia = float(np.median(neighbours.joint_inertia_kg_m2))
    per_implicit = dt_s / (inertia + dt_s * damping)  # MuJoCo's implicit damping, per step
    law = _Law(
        half_band=np.radians(figures["deadband_deg"]) / 2,
        kp=figures["kp_nm_rad"],
        stall=stall,
        friction=figures["friction_nm"],
        per_implicit=per_implicit,
        keep_v=inertia * per_implicit / dt_s,
        # MuJoCo's soft dry friction (``SoftFriction``): below its limit it takes back all
        # but a share of the torque and aims to stop the joint; it holds no joint dead still
        held=-1 / (1 + inertia * load.friction.softness),
        stopping=inertia * load.friction.damping_per_s - damping,
        grid_rad=np.radians(load.angles_deg),
        gravity_nm=load.gravity_nm,
        supply_sag_per_nm=supply_sag_per_nm,
        dt_s=dt_s,
    )
    aim = wanted[0].copy()
    first_read = np.radians(trial.read_deg[0]) if len(trial.read_deg) else aim
    positions = np.empty((n_steps, k))
    pushing = np.zeros((n_steps if record else 0, k))
    low_edge = wanted - half_play
    high_edge = np.add(wanted, half_play, wanted)  # (wanted's buffer: it is not read again)
    steps = _Steps(low_edge, high_edge, loaded, reloads, neighbours.torque_nm)
    _step_all(law, steps, np.full(k, first_read) + offset, aim, positions, pushing)
    positions -= offset
    return times, positions, pushing


@dataclass(frozen=True)
class _Law:
    """The servo's law and the joint's dynamics, one entry per candidate (or one for all)."""

    half_band: np.ndarray
    kp: np.ndarray
    stall: np.ndarray
    friction: np.ndarray
    per_implicit: np.ndarray
    keep_v: np.ndarray
    held: float
    stopping: np.ndarray
    grid_rad: np.ndarray
    gravity_nm: np.ndarray
    supply_sag_per_nm: float
    dt_s: float


@dataclass(frozen=True)
class _Steps:
    """What each step brings, one row per step: the play's edges around the set-point, whether
    the servo is loaded, the steps it loads again at (``_aims``), the neighbours' push."""

    low_edge: np.ndarray
    high_edge: np.ndarray
    loaded: np.ndarray
    reloads: set[int]
    neighbours_nm: np.ndarray


def _step_all(
    law: _Law,
    steps: _Steps,
    q: np.ndarray,
    aim: np.ndarray,
    positions: np.ndarray,
    pushing: np.ndarray,
) -> None:
    """Every step from angle ``q`` and aim ``aim`` (radians, with the offset): each
    candidate's angle after it into ``positions`` and, if ``pushing`` has rows, its servo's
    torque. This loop is the cost of the whole fit (it runs ~4,000 times per candidate
    generation, each numpy call in it on a few dozen candidates, whose cost is per call, not
    per element): so buffers kept, ``clip`` ufunc calls, products made several at a time in one
    call on stacked rows, and the ufuncs called as local names with their output passed by
    position (a keyword and a module attribute cost 15 % of a call more)."""
    k = len(q)
    add, subtract, multiply, absolute, clip, interp = (
        np.add,
        np.subtract,
        np.multiply,
        np.absolute,
        _clip,
        _interp,
    )
    error, inside, pull = np.empty((3, k))
    # the scalars as arrays: numpy converts a Python float anew at each call, which costs
    # half as much again as the call
    one, held = np.ones(k), np.full(k, law.held)
    # [torque, its size] * [sag, -sag per N·m]: the sagged torque and the next sag less 1
    torque_and_size = np.empty((2, k))
    sag_and_per_nm = np.array([one, np.full(k, -law.supply_sag_per_nm)])
    torque, size, sag = torque_and_size[0], torque_and_size[1], sag_and_per_nm[0]
    band_low, stall_low, friction_low = -law.half_band, -law.stall, -law.friction
    half_band, kp, stall, friction = law.half_band, law.kp, law.stall, law.friction
    grid_rad, gravity_nm, per_implicit = law.grid_rad, law.gravity_nm, law.per_implicit
    # [step, kept velocity, grip] = [dt, keep_v, stopping] * v + [0, per_implicit, 1] * torque:
    # the products with v made at the end of a step, for its step and the next one's sums
    v = np.zeros(k)
    of_v_by = np.array([np.full(k, law.dt_s), law.keep_v, law.stopping])
    of_v = np.multiply(of_v_by, v)
    step_q, kept_and_grip = of_v[0], of_v[1:]
    of_torque_by = np.array([per_implicit, one])
    of_torque, sums = np.empty((2, 2, k))
    free_v, grip = sums
    sagging, record = law.supply_sag_per_nm, len(pushing) > 0
    reloads = steps.reloads
    # the neighbours' push a row of candidates a step (a scalar costs a conversion each call)
    neighbours_nm = np.broadcast_to(steps.neighbours_nm[:, None], (len(steps.neighbours_nm), k))
    rows = zip(steps.low_edge, steps.high_edge, steps.loaded.tolist(), neighbours_nm, positions)
    for step, (low, high, loaded, pushed_nm, after) in enumerate(rows):
        if step in reloads:
            aim = q.copy()
        clip(aim, low, high, aim)
        subtract(aim, q, error)
        subtract(error, clip(error, band_low, half_band, inside), pull)
        if loaded:
            clip(multiply(kp, pull, torque), stall_low, stall, torque)
            # torque and gain at the supply the last step's push left (as the physics emulator
            # has it); the back-EMF damping does not sag
            if sagging:
                absolute(torque, size)
                multiply(torque_and_size, sag_and_per_nm, torque_and_size)
                add(size, one, sag)
            if record:
                absolute(torque, pushing[step])
        else:
            torque.fill(0.0)
            sag.fill(1.0)
        add(torque, interp(q, grid_rad, gravity_nm), torque)
        add(torque, pushed_nm, torque)
        multiply(of_torque_by, torque, of_torque)
        add(kept_and_grip, of_torque, sums)
        multiply(grip, held, grip)
        clip(grip, friction_low, friction, grip)
        multiply(per_implicit, grip, v)
        add(v, free_v, v)
        multiply(of_v_by, v, of_v)
        q = add(q, step_q, after)


def push_of_neighbours(trial: Trial, load: JointLoad, dt_s: float) -> NeighbourPush:
    """What the neighbours read in ``trial`` do to the joint, on steps of ``dt_s``
    (``neighbours.neighbour_push``; their servos at the supply read)."""
    n_steps = int(np.ceil(trial.duration_s / dt_s)) + 2
    supply_v = float(np.median(trial.supply.volts)) if trial.supply else None
    return neighbour_push(
        trial.neighbours, load, trial.read_s, trial.read_deg, dt_s, n_steps, supply_v
    )


def _aims(
    trial: Trial, figures: dict[str, np.ndarray], n_steps: int, dt_s: float
) -> tuple[np.ndarray, np.ndarray, set[int]]:
    """Each step's set-point, late by each candidate's delay, through its offset (n_steps, k)
    radians; whether the servo is loaded at each step; the steps where it loads again after a
    drop (from where it reads then: it starts from its potentiometer)."""
    k = len(figures["kp_nm_rad"])
    speed = np.radians(figures["no_load_speed_deg_s"])
    times = np.arange(n_steps) * dt_s
    setpoints = np.empty((n_steps, k))
    loaded = np.ones(n_steps, dtype=bool)
    reloads: set[int] = set()
    here = np.full(k, np.radians(trial.start_setpoint_deg))
    commands = sorted(trial.commands, key=lambda c: c.at_s)
    bounds = [int(np.ceil(c.at_s / dt_s - 1e-9)) for c in commands] + [n_steps]
    setpoints[: bounds[0]] = here
    unloaded = False
    next_at = [c.at_s for c in commands[1:]] + [times[-1]]
    for command, begin, end, until_s in zip(commands, bounds[:-1], bounds[1:], next_at):
        begin, end = min(begin, n_steps), min(end, n_steps)
        if isinstance(command, Unload):
            loaded[begin:end] = False
            setpoints[begin:end] = here
            unloaded = True
            continue
        if unloaded:  # a move after a drop starts where the servo reads
            index = max(int(np.searchsorted(trial.read_s, command.at_s)) - 1, 0)
            here = np.full(k, np.radians(trial.read_deg[index]))
            reloads.add(begin)
            unloaded = False
        delta = np.radians(command.target_deg) - here
        duration = np.maximum(command.time_s, np.abs(delta) / speed)
        elapsed = np.maximum(times[begin:end, None] - command.at_s, 0.0)
        setpoints[begin:end] = here + delta * np.minimum(elapsed / np.maximum(duration, 1e-9), 1.0)
        moved = np.minimum(max(until_s - command.at_s, 0.0) / np.maximum(duration, 1e-9), 1.0)
        here = here + delta * moved  # where the next command finds the set-point
    # each step's set-point late by the delay: between two steps' (the flat array's rows), in
    # buffers kept over the (steps, k) arrays, which are a fit's largest (a fresh one's pages
    # cost as much as filling it)
    late = np.arange(n_steps)[:, None] - figures["response_delay_s"][None, :] / dt_s
    _clip(late, 0, n_steps - 1, late)
    part = np.floor(late)
    below = part.astype(np.intp)
    np.subtract(late, part, part)  # the share of the later step's
    below *= k  # where each candidate's earlier step is in the flat set-points
    below += np.arange(k)
    delayed = setpoints.take(below)
    np.minimum(below + k, setpoints.size - k + np.arange(k), out=below)  # the later (or last)
    later = setpoints.take(below)
    np.multiply(delayed, np.subtract(1, part, late), delayed)
    delayed += np.multiply(later, part, later)
    delayed += np.radians(figures["offset_deg"])[None, :]
    return delayed, loaded, reloads


def reading_error_deg(trial: Trial, predicted_deg: np.ndarray) -> np.ndarray:
    """Each candidate's absolute errors against the reads, (reads, k) degrees."""
    return np.abs(predicted_deg - trial.read_deg[:, None])


def figures_of(rows: Sequence[dict[str, float]]) -> dict[str, np.ndarray]:
    """Candidates given one dict each, as the arrays :func:`simulate` takes."""
    return {name: np.array([row[name] for row in rows], dtype=float) for name in FIGURES}
