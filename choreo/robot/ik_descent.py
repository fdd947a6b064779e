"""The inverse kinematics' damped least squares, on arrays (no MuJoCo here): what a task asks
(``Task``), its residuals and Jacobians at a batch of poses (``linearise``), a step held inside
the joint limits (``limited_step``) and the descent of many starts side by side (``descend``).
``kinematics.Kinematics`` poses the robot for it and keeps what it finds."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

POSITION_TOLERANCE_MM = 0.5  # a solution this close (and within the angle tolerance) is reached
ANGLE_TOLERANCE_DEG = 0.5
_CONVERGED_MM, _CONVERGED_DEG = 0.02, 0.02
_DAMPING = 1e-4
# a step that made things worse is retried with 10 times the damping; one that helped eases it
_STIFFEN, _EASE = 10.0, 3.0
# a descent that has not cut its residual by 10 % in 10 steps is stuck (a fold, a limit): stop it;
# the last one, polishing the closest point of a target out of reach, goes on down to 1 %
_PROGRESS, POLISH_PROGRESS, _PATIENCE = 0.1, 0.01, 10
_STILL_RAD = 1e-7  # a step this small: the descent is at its closest, reached or not
_MAX_STEP_RAD = 0.3
_POSITION_WEIGHT = 10.0  # residual rows: metres x 10 (1 mm ~ 0.01) next to radians (1° ~ 0.017)


@dataclass(frozen=True)
class Task:
    """What the goals ask, as arrays: every site's position (m), the pitched ones' pitch."""

    sites: np.ndarray  # (sites,) MuJoCo site ids, goal order
    moves: np.ndarray  # (sites, joints) bool: the joint moves the site
    targets: np.ndarray  # (sites, 3) metres, base frame
    pitched: np.ndarray  # (sites,) bool: the goal asks for a pitch
    pitch_deg: np.ndarray  # (pitched sites,)
    pitch_cos_sin: np.ndarray  # (pitched sites, 2)


@dataclass(frozen=True)
class Attempts:
    """Where a batch of descents ended (rows), with the solver's own errors there."""

    angles_deg: np.ndarray  # (N, joints)
    error_mm: np.ndarray  # (N, sites)
    pitch_error_deg: np.ndarray  # (N, pitched sites)

    @property
    def reached(self) -> np.ndarray:
        return np.all(self.error_mm <= POSITION_TOLERANCE_MM, axis=1) & np.all(
            self.pitch_error_deg <= ANGLE_TOLERANCE_DEG, axis=1
        )

    @property
    def cost(self) -> np.ndarray:  # mm and degrees alike, as the tolerances are
        return self.error_mm.sum(axis=1) + self.pitch_error_deg.sum(axis=1)


@dataclass(frozen=True)
class Poses:
    """Where the task's sites are for a batch of joint vectors (N), in the base frame (m)."""

    positions: np.ndarray  # (N, sites, 3)
    z_axes: np.ndarray  # (N, sites, 3) each site's z axis (its pitch is that axis' elevation)
    jac_position: np.ndarray  # (N, sites, 3, joints) d position / d joint (rad, m)
    jac_turn: np.ndarray  # (N, sites, 3, joints) each joint's angular velocity, where it turns


def descend(
    task: Task,
    start_deg: np.ndarray,
    free: np.ndarray,
    iterations: int,
    limits_deg: tuple[np.ndarray, np.ndarray],
    poses: Callable[[Task, np.ndarray], Poses],
    progress_needed: float | None = None,
) -> Attempts:
    """Damped least squares from each start (rows) at once, Levenberg-Marquardt style: a
    step that makes things worse is taken back and retried with more damping (near a
    singularity or out of reach, where plain steps swing back and forth). A start stops when
    it has converged, when its steps vanish (it is as close as it gets), or when it has not
    cut its residual by ``progress_needed`` in ``_PATIENCE`` steps (in a fold, at a limit).
    Only the ``free`` joints move, inside ``limits_deg`` (lower, upper); ``poses`` gives the
    task's sites and Jacobians at joint vectors (radians)."""
    free_at = np.flatnonzero(free)
    low, high = (np.radians(limit[free_at]) for limit in limits_deg)
    q = np.radians(start_deg)
    descent = _Descent(q, task, progress_needed or _PROGRESS)
    moving = np.arange(len(q))
    for iteration in range(iterations + 1):
        descent.take(moving, q, linearise(task, poses(task, q[moving])), iteration)
        going = descent.going(moving, iteration)
        if iteration == iterations or not going.any():
            break
        moving = moving[going]
        q[moving] = descent.step(moving, free_at, low, high)
    angles_deg = start_deg.copy()  # held joints exactly as given, not via radians
    angles_deg[:, free_at] = np.degrees(descent.best_q[:, free_at])
    return Attempts(angles_deg, descent.errors, descent.pitch_errors)


class _Descent:
    """A batch of descents (rows): each row's best point yet, its errors, residual and Jacobian
    there, its damping, when it last made progress and whether its steps have vanished."""

    def __init__(self, q: np.ndarray, task: Task, progress_needed: float):
        n = len(q)
        self.progress_needed = progress_needed
        self.best_q, self.best = q.copy(), np.full(n, np.inf)
        self.errors = np.zeros((n, len(task.targets)))
        self.pitch_errors = np.zeros((n, len(task.pitch_deg)))
        self.damping = np.full(n, _DAMPING)
        self.progress, self.since = self.best.copy(), np.zeros(n, int)
        self.still = np.zeros(n, bool)
        self.residuals = self.jacobians = np.empty(0)

    def take(
        self,
        moving: np.ndarray,
        q: np.ndarray,
        linearised: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        iteration: int,
    ) -> None:
        """Keep each moving row's point ``q`` where it is the row's best yet (easing its damping),
        else stiffen its damping; note the rows that made progress."""
        residual, jacobian, error_mm, pitch_error = linearised
        if iteration == 0:
            self.residuals, self.jacobians = np.empty_like(residual), np.empty_like(jacobian)
        cost = np.linalg.norm(residual, axis=1)
        better = cost < self.best[moving]
        at = moving[better]
        self.best[at], self.best_q[at] = cost[better], q[at]
        self.errors[at], self.pitch_errors[at] = error_mm[better], pitch_error[better]
        self.residuals[at], self.jacobians[at] = residual[better], jacobian[better]
        self.damping[at] = np.maximum(_DAMPING, self.damping[at] / _EASE)
        self.damping[moving[~better]] *= _STIFFEN
        advanced = moving[self.best[moving] < self.progress[moving] * (1 - self.progress_needed)]
        self.progress[advanced], self.since[advanced] = self.best[advanced], iteration

    def going(self, moving: np.ndarray, iteration: int) -> np.ndarray:
        """Which moving rows go on: not converged, still stepping, and not stuck."""
        converged = np.all(self.errors[moving] <= _CONVERGED_MM, axis=1) & np.all(
            self.pitch_errors[moving] <= _CONVERGED_DEG, axis=1
        )
        return ~converged & ~self.still[moving] & (iteration - self.since[moving] < _PATIENCE)

    def step(
        self, moving: np.ndarray, free_at: np.ndarray, low: np.ndarray, high: np.ndarray
    ) -> np.ndarray:
        """The next point of each moving row: a damped step from its best point, held inside
        the limits."""
        start = self.best_q[moving]
        step = limited_step(
            self.jacobians[moving][:, :, free_at],
            self.residuals[moving],
            start[:, free_at],
            low,
            high,
            self.damping[moving],
        )
        start[:, free_at] = np.clip(start[:, free_at] + step, low, high)
        self.still[moving] = np.abs(step).max(axis=1, initial=0.0) < _STILL_RAD
        return start


def linearise(task: Task, poses: Poses) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For a batch of poses: the stacked weighted residuals ``(N, rows)``, their Jacobians
    ``(N, rows, joints)``, each site's distance (mm) and each pitch's error (deg)."""
    n, joints = len(poses.positions), poses.jac_position.shape[-1]
    error = task.targets - poses.positions
    rows = [_POSITION_WEIGHT * error.reshape(n, -1)]
    jacobians = [_POSITION_WEIGHT * poses.jac_position.reshape(n, -1, joints)]
    axes = poses.z_axes[:, task.pitched]
    pitch_deg = np.degrees(np.arcsin(np.clip(axes[..., 2], -1.0, 1.0)))
    if task.pitched.any():
        positions = poses.positions[:, task.pitched]
        target, follow = axis_with_pitch(axes, positions, task.pitch_cos_sin)
        rows.append((target - axes).reshape(n, -1))
        # d(axis)/dq = omega x axis, omega the joint's angular velocity; the target turns with
        # the axis' heading, which leaves the axis' elevation for these rows to ask for
        omega = np.swapaxes(poses.jac_turn[:, task.pitched], 2, 3)
        turning = cross(omega, axes[:, :, None, :])  # (N, pitched, joints, 3)
        turning[..., :2] -= np.einsum("npij,npkj->npki", follow, turning[..., :2])
        jacobians.append(np.swapaxes(turning, 2, 3).reshape(n, -1, joints))
    return (
        np.concatenate(rows, axis=1),
        np.concatenate(jacobians, axis=1),
        np.linalg.norm(error, axis=2) * 1000,
        np.abs(pitch_deg - task.pitch_deg),
    )


def limited_step(
    jacobian: np.ndarray,
    residual: np.ndarray,
    q: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    damping: np.ndarray,
) -> np.ndarray:
    """Damped least-squares steps (rows, each with its damping); joints at a limit a step would
    push past are held out of it (their Jacobian column zeroed leaves them out of the solve)."""
    active = np.ones(q.shape, bool)
    damped = damping[:, None, None] * np.eye(jacobian.shape[1])
    for _ in range(3):
        j = jacobian * active[:, None, :]
        jt = np.swapaxes(j, 1, 2)
        step = (jt @ np.linalg.solve(j @ jt + damped, residual[..., None]))[..., 0]
        blocked = ((q <= low + 1e-9) & (step < 0)) | ((q >= high - 1e-9) & (step > 0))
        if not (blocked & active).any():
            break
        active &= ~blocked
    largest = np.abs(step).max(axis=1, initial=0.0)
    return step * np.minimum(1.0, _MAX_STEP_RAD / np.maximum(largest, 1e-12))[:, None]


_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` over the last axis, broadcast; a third of its cost (it runs at every step)."""
    return np.einsum("ijk,...j,...k->...i", _LEVI_CIVITA, a, b)


def pitch_deg(axis: np.ndarray) -> float:
    return float(np.degrees(np.arcsin(np.clip(axis[2], -1.0, 1.0))))


def axis_with_pitch(
    axis: np.ndarray, position: np.ndarray, pitch: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The unit vectors at elevation ``pitch`` (``(..., 2)``: its cosine and sine) nearest
    ``axis`` (``(..., 3)``): same heading, or, where the axis is vertical, heading away from the
    base axis towards the site. Also how they turn with the axis' horizontal part (``(..., 2,
    2)``): the target follows the heading, so only the elevation is asked for."""
    heading = axis[..., :2]
    norm = np.hypot(heading[..., :1], heading[..., 1:])
    vertical = norm < 1e-3
    if vertical.any():  # rare: (nearly) vertical, and even on the base axis
        heading = np.where(vertical, position[..., :2], heading)
        norm = np.hypot(heading[..., :1], heading[..., 1:])
        heading = np.where(norm > 1e-9, heading, [1.0, 0.0])
        norm = np.where(norm > 1e-9, norm, 1.0)
    unit = heading / norm
    target = np.concatenate(
        [pitch[..., :1] * unit, np.broadcast_to(pitch[..., 1:], norm.shape)], -1
    )
    # cos(pitch) times the derivative of the unit heading (none where the position gave it)
    follow = np.where(vertical, 0.0, pitch[..., :1] / norm)[..., None]
    turning = follow * (np.eye(2) - unit[..., :, None] * unit[..., None, :])
    return target, turning
