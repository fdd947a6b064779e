"""The joint's neighbours in the chain, each a servo holding where it was told, moved by the
joint: what they do to the joint in identify's joint model.

The others hold with their own servos, and the neighbours yield under the torque the joint puts
out (on arm6 the shoulder gives way 3-5° under the elbow's test steps): a model of the joint on a
rigid base takes that for a softer servo. Their reads cannot simply be replayed: a read is whole
units (0.24°), and their rounding noise in a neighbour's slow motion passes for friction (the
elbow's came out 15-38 % high), while its fast motion, a fortieth of a unit, carries the joint's
timing (every smoothing of the reads that took the noise away took 7-26 % off the fitted delay).

So the neighbours read are simulated, as the joint moved (its reads): their inertia and the
mass matrix between them and with the joint (``JointLoad``), the gravity on them (which the
joint's angle changes, as theirs changes the joint's), and their servos' law holding them (dead
band, gain up to the stall torque, back-EMF damping: the figures identify measured for them
earlier, in this run or in its file, else the robot file's). Their reads
add what that model cannot know, slowly (over ``SLOW_S``): where they stood, how they sagged,
whatever their servos' real figures. On the joint, the mass matrix's coupling is eliminated
exactly (its inertia with them free to move, and what their own torque pushes it with), so the
joint's own acceleration stays each candidate's: only their torque, a function of where they
are and how fast they go (no acceleration read twice from whole units), is worked out once per
trial and step. Neighbours not coupled to the joint, or not read, stand rigid.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from choreo.identify.compiled import clip
from choreo.preview.actuator import ActuatorParams
from choreo.preview.joint_load import JointLoad

# what the model of a neighbour misses is taken from its reads over this (a Gaussian's sigma):
# slower than its ringing (~10 Hz on arm6), so their rounding noise does not reach the joint
SLOW_S = 0.05
# where it starts: its first reads, over this
START_SMOOTHING_S = 0.01
# the joint's own reads, which move the neighbours, are smoothed over this: a read unit's step
# would kick them
JOINT_SMOOTHING_S = 0.007


@dataclass(frozen=True)
class NeighbourReads:
    """A neighbour's position reads during the joint's moves (midpoint times, degrees in its
    servo's frame), and where it was told to hold."""

    joint: str
    read_s: np.ndarray
    read_deg: np.ndarray
    held_deg: float

    @property
    def moved_deg(self) -> float:
        """How far it went from where it holds, at most."""
        return float(np.abs(self.read_deg - self.held_deg).max(initial=0.0))


@dataclass(frozen=True)
class NeighbourPush:
    """What the neighbours do to the joint at each step: the torque they put on it, the same
    for every candidate (N·m), and the joint's inertia with them free to move (kg·m²)."""

    torque_nm: np.ndarray
    joint_inertia_kg_m2: np.ndarray
    # where each neighbour was (degrees from where it holds, (steps, neighbours))
    neighbours_deg: np.ndarray


def neighbour_push(
    trial_reads: Sequence[NeighbourReads],
    load: JointLoad,
    joint_read_s: np.ndarray,
    joint_read_deg: np.ndarray,
    dt_s: float,
    n_steps: int,
    supply_v: float | None = None,
) -> NeighbourPush:
    """The neighbours read, simulated as servos holding, moved by the joint as it read
    (``joint_read_s``, ``joint_read_deg``), with what that misses slowly from their own reads;
    on ``n_steps`` steps of ``dt_s`` (the state after each); their servos at ``supply_v``
    (else at their figures' own).

    In each step, with M the mass matrix among the neighbours, c their coupling with the joint,
    D their damping and f the torque on them (their servos, gravity, minus D times their
    velocity), MuJoCo's implicit step ``(M + dt D) a + c a_joint = f`` gives their acceleration
    ``a = (M + dt D)⁻¹ (f - c a_joint)``; the joint's row then reads ``(I - cᵀ(M + dt D)⁻¹c)
    a_joint = τ_joint - cᵀ(M + dt D)⁻¹ f``: its inertia lightened, pushed back by their torque."""
    # (one function: the arrays it lays out per step are for its loop, which is all it does)
    order = {coupling.joint: n for n, coupling in enumerate(load.neighbours)}
    used = [r for r in trial_reads if r.joint in order and len(r.read_s) >= 2]
    times = np.arange(1, n_steps + 1) * dt_s
    if len(joint_read_s):
        joint_deg = np.interp(times, joint_read_s, joint_read_deg)
        joint_deg = _smoothed(joint_deg, dt_s, JOINT_SMOOTHING_S)
    else:
        joint_deg = np.zeros(n_steps)
    inertia = load.inertia_at(np.radians(joint_deg))
    if not used:
        return NeighbourPush(np.zeros(n_steps), inertia, np.zeros((n_steps, 0)))
    # the neighbours read, then those they carry (not read: the model alone moves them)
    carried = [len(order) + n for n in range(len(load.carried))]
    rows = np.array([order[r.joint] for r in used] + carried)
    couplings = [load.neighbours[order[r.joint]] for r in used] + list(load.carried)

    def over_steps(grid: np.ndarray) -> np.ndarray:  # (grid, ...) -> (n_steps, ...)
        flat = grid.reshape(len(grid), -1)
        at = [np.interp(joint_deg, load.angles_deg, flat[:, i]) for i in range(flat.shape[1])]
        return np.array(at).T.reshape((n_steps, *grid.shape[1:]))

    def per_neighbour(name: str) -> np.ndarray:  # (n_steps, neighbours)
        return over_steps(np.array([getattr(c, name) for c in couplings]).T)

    half_band, kp, stall, damping = _servos([c.servo for c in couplings], supply_v)
    mass = over_steps(load.neighbour_inertia_kg_m2[:, rows][:, :, rows])
    # their damping taken at the step's end: what turns their torque into their motion
    per_implicit = dt_s * np.linalg.inv(mass + dt_s * np.diag(damping))
    coupling = per_neighbour("inertia_kg_m2")
    through = np.einsum("sab,sb->sa", per_implicit, coupling) / dt_s  # their torque's push back
    # the gravity on them where they hold, and per radian they moved
    steady = per_neighbour("held_gravity_nm")
    per_rad = over_steps(load.neighbour_gravity_nm_rad[:, rows][:, :, rows])
    read = np.array([np.interp(times, r.read_s, r.read_deg) - r.held_deg for r in used]).T
    joint_per_rad = per_neighbour("gravity_nm_rad")
    joint_velocity = np.gradient(np.radians(joint_deg), dt_s)
    joint_change = np.diff(joint_velocity, prepend=joint_velocity[0])
    # from where the read ones read, the others where their servos hold them against gravity
    moved = np.radians(_smoothed(read, dt_s, START_SMOOTHING_S)[0])
    moved = np.concatenate([moved, _sagged(steady[0], per_rad[0], half_band, kp)[len(used) :]])
    velocity = np.zeros(len(rows))
    pushed, modelled = np.empty(n_steps), np.empty((n_steps, len(rows)))
    # (the bounds negated once, and the clip ufunc itself: np.clip's wrappers cost more than it)
    band_low, minus_kp, stall_low = -half_band, -kp, -stall
    for step in range(n_steps):
        pull = moved - clip(moved, band_low, half_band)
        torque = clip(minus_kp * pull, stall_low, stall) + steady[step] + per_rad[step] @ moved
        torque -= damping * velocity
        pushed[step] = joint_per_rad[step] @ moved - through[step] @ torque
        velocity += per_implicit[step] @ torque - through[step] * joint_change[step]
        moved += dt_s * velocity
        modelled[step] = moved
    # what the model misses, slowly, from the reads: where they stood, how they sagged
    missed = np.zeros_like(modelled)
    missed[:, : len(used)] = _smoothed(np.radians(read) - modelled[:, : len(used)], dt_s, SLOW_S)
    missed_acceleration = np.gradient(np.gradient(missed, dt_s, axis=0), dt_s, axis=0)
    pushed += np.einsum("sa,sa->s", joint_per_rad, missed)
    pushed -= np.einsum("sa,sa->s", coupling, missed_acceleration)
    return NeighbourPush(
        pushed,
        inertia - np.einsum("sa,sa->s", coupling, through),
        np.degrees(modelled + missed),
    )


def _sagged(
    gravity_nm: np.ndarray, per_rad: np.ndarray, half_band: np.ndarray, kp: np.ndarray
) -> np.ndarray:
    """Where servos holding at 0 stand against ``gravity_nm`` (radians): past their dead band
    by the gravity over their gain, less its own slope (each on its own)."""
    slope = np.diagonal(per_rad)
    return (gravity_nm + np.sign(gravity_nm) * kp * half_band) / (kp - slope)


def _servos(servos: Sequence[ActuatorParams], supply_v: float | None) -> tuple[np.ndarray, ...]:
    """The servos' half dead band (radians), gain and stall torque at ``supply_v`` (as
    ``fit.at_supply`` scales the joint's; else at their own supply) and back-EMF damping."""
    scale = np.array([(supply_v or s.supply_v) / s.supply_v for s in servos])
    return (
        np.radians([s.deadband_deg for s in servos]) / 2,
        np.array([s.kp_nm_rad for s in servos]) * scale,
        np.array([s.stall_torque_nm for s in servos]) * scale,
        np.array([s.damping_nm_s_rad for s in servos]),
    )


def _smoothed(values: np.ndarray, dt_s: float, sigma_s: float) -> np.ndarray:
    """``values`` (on steps ``dt_s`` apart, along the first axis) through a Gaussian of
    ``sigma_s``."""
    sigma = sigma_s / dt_s
    half = int(np.ceil(3 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(values, [(half, half)] + [(0, 0)] * (values.ndim - 1), mode="edge")
    return np.apply_along_axis(np.convolve, 0, padded, kernel, mode="valid")
