"""Forward and inverse kinematics of a robot's named sites, on its MuJoCo model.

    kin = Kinematics(robot)
    kin.site_pose("tool", angles_deg)                    # where the tool is: mm, base frame
    solution = kin.solve([SiteGoal("tool", (160, 0, 40), pitch_deg=-80)], seed_deg)

Positions are in millimetres in the robot's base frame (the first body of its MJCF: an arm's
base, a walker's torso, held where the model's ``home`` keyframe puts it). A site's pitch is the
elevation of its z axis (its approach direction) above the base frame's horizontal plane:
+90 points up, -90 straight down.

IK is damped least squares (``ik_descent``; Levenberg-Marquardt: a step that makes things worse is
retried with more damping) inside the robot's joint limits (a joint at a limit that the step would
push further drops out of the step), seeded by the caller (the previous keyframe). If that gets
stuck, fixed random restarts are drawn ever farther from the seed, 20 at a time, and descended side
by side as arrays; of those that reach, the solution nearest the seed is kept (so a small move in
space stays a small move in joints), and joints the goals do not constrain stay where they were.
Each step poses the robot with MuJoCo's ``mj_kinematics`` (a couple of microseconds per start) and
builds the Jacobians from the joints' axes and anchors; a descent stops as soon as it has converged,
stalls or stops moving, so a target out of reach fails in tens of milliseconds. The verdict
(``Solution``) is MuJoCo's own forward kinematics of the angles found. ``mujoco`` is imported here
only when a ``Kinematics`` is made: motions without Cartesian keyframes never load it. (mink, a QP
IK library on MuJoCo, would also do, but needs qpsolvers and a QP solver; these tasks — site
positions, one axis' elevation, joint limits — are small enough for damped least squares.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np
import numpy.typing as npt

from choreo.errors import ChoreoError
from choreo.robot.ik_descent import (
    ANGLE_TOLERANCE_DEG,
    POLISH_PROGRESS,
    POSITION_TOLERANCE_MM,
    Attempts,
    Poses,
    Task,
    cross,
    descend,
    linearise,
    pitch_deg,
)
from choreo.robot.types import Robot

_ITERATIONS = 400
_RESTARTS = 60  # random starts (fewer iterations each) when the seed gets stuck
_RESTART_ITERATIONS = 30
_RESTARTS_AT_ONCE = 20  # descended side by side, as arrays
_MIRRORED = 24  # starts on other branches when every restart ends short (an arm's 4 joints: 10)
FEET_TEXT = "choreo:feet"  # MJCF <custom><text name=... data="site site ..."/>: a walker's feet


@dataclass(frozen=True)
class SiteGoal:
    """Where one site should be: position (mm, base frame) and optionally its pitch."""

    site: str
    position_mm: tuple[float, float, float]
    pitch_deg: float | None = None


@dataclass(frozen=True)
class SitePose:
    position_mm: np.ndarray  # (3,) base frame
    pitch_deg: float


@dataclass(frozen=True)
class Solution:
    angles_deg: np.ndarray  # every robot joint, robot order, inside the limits
    reached: tuple[SitePose, ...]  # where each goal's site ends up, goal order
    position_error_mm: tuple[float, ...]
    pitch_error_deg: tuple[float, ...]  # 0 for goals without a pitch

    @property
    def ok(self) -> bool:
        return (
            max(self.position_error_mm, default=0.0) <= POSITION_TOLERANCE_MM
            and max(self.pitch_error_deg, default=0.0) <= ANGLE_TOLERANCE_DEG
        )


def _mujoco() -> Any:
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is a core dependency today
        raise ChoreoError(
            "Cartesian keyframes need MuJoCo: pip install mujoco (or choreo[preview])"
        ) from None
    return mujoco


class Kinematics:
    """A robot's MuJoCo model kept for forward/inverse kinematics of its sites."""

    def __init__(self, robot: Robot) -> None:
        if robot.mjcf_path is None:
            raise ChoreoError(
                f"robot {robot.name} has no MuJoCo model: Cartesian keyframes need "
                f"mjcf: in {robot.path}"
            )
        mj = self._mj = _mujoco()
        from choreo.robot.compiled_model import compiled_model  # imports mujoco

        self.robot = robot
        self.model = compiled_model(robot.mjcf_path)
        self.data = mj.MjData(self.model)
        home = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_KEY, "home")
        if home >= 0:
            mj.mj_resetDataKeyframe(self.model, self.data, home)
        joint_ids = [
            mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_JOINT, j.mjcf_joint) for j in robot.joints
        ]
        self._joint_ids = np.array(joint_ids)
        self._qpos = np.array([self.model.jnt_qposadr[i] for i in joint_ids])
        # a servo turns a hinge; a slide (a linear actuator) moves along its axis
        self._hinge = np.array(
            [self.model.jnt_type[i] == mj.mjtJoint.mjJNT_HINGE for i in joint_ids]
        )
        self.lower_deg = np.array([j.limits.min_deg for j in robot.joints], dtype=float)
        self.upper_deg = np.array([j.limits.max_deg for j in robot.joints], dtype=float)
        self._base = 1  # the robot's first body; IK holds it (and any free joint) in place
        mj.mj_kinematics(self.model, self.data)
        self._base_pos = self.data.xpos[self._base].copy()
        self._base_rot = self.data.xmat[self._base].reshape(3, 3).copy()
        # per kind of task (its sites, which have a pitch): a motion asks the same ones again
        self._moves: dict[tuple[int, ...], np.ndarray] = {}
        self._constrained_joints: dict[tuple[tuple[int, ...], tuple[bool, ...]], np.ndarray] = {}
        self._site_ids: dict[str, int] = {}  # the sites asked for by name

    # --- names --------------------------------------------------------------------------------

    @property
    def site_names(self) -> tuple[str, ...]:
        return tuple(self.model.site(i).name for i in range(self.model.nsite))

    def site_id(self, name: str) -> int:
        return int(self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_SITE, name))

    def feet(self) -> tuple[str, ...]:
        """The walker's foot sites, as its MJCF lists them (empty if it lists none)."""
        text = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_TEXT, FEET_TEXT)
        if text < 0:
            return ()
        start = self.model.text_adr[text]
        raw = bytes(self.model.text_data[start : start + self.model.text_size[text]])
        return tuple(raw.rstrip(b"\0").decode().split())

    # --- frames -------------------------------------------------------------------------------

    @property
    def base_body(self) -> str:
        """The body whose frame positions are given in (the MJCF's first body)."""
        return str(self.model.body(self._base).name)

    def world_to_base_mm(self, world_mm: npt.ArrayLike) -> np.ndarray:
        """A point given in the world (with the robot standing at home) in the base frame."""
        return self._base_rot.T @ (np.asarray(world_mm, dtype=float) / 1000 - self._base_pos) * 1000

    # --- forward kinematics -------------------------------------------------------------------

    def _set(self, angles_deg: np.ndarray) -> None:
        self.data.qpos[self._qpos] = np.radians(angles_deg)
        self._mj.mj_kinematics(self.model, self.data)

    def _site_in_base(self, site: int) -> tuple[np.ndarray, np.ndarray]:
        """(position m, z axis) of a site in the base frame, for the joints last set."""
        position = self._base_rot.T @ (self.data.site_xpos[site] - self._base_pos)
        axis = self._base_rot.T @ self.data.site_xmat[site].reshape(3, 3)[:, 2]
        return position, axis

    def site_pose(self, site: str, angles_deg: npt.ArrayLike) -> SitePose:
        self._set(np.asarray(angles_deg, dtype=float))
        position, axis = self._site_in_base(self._checked_site(site))
        return SitePose(position * 1000, pitch_deg(axis))

    def site_positions_mm(self, sites: Sequence[str], angles_deg: npt.ArrayLike) -> np.ndarray:
        """Where each of ``sites`` is (mm, base frame; one row each) at ``angles_deg``: the
        positions ``site_pose`` gives, from one forward kinematics for all of them (a walker's
        feet are asked at every sample of a motion)."""
        self._set(np.asarray(angles_deg, dtype=float))
        known = self._site_ids
        ids = [known[site] if site in known else self._checked_site(site) for site in sites]
        rotation, base, xpos = self._base_rot.T, self._base_pos, self.data.site_xpos
        # one matrix product per site as ``site_pose`` does (the same numbers), in one call
        return np.matmul(rotation, (xpos[ids] - base)[:, :, None])[:, :, 0] * 1000

    def _checked_site(self, name: str) -> int:
        site = self.site_id(name)
        if site < 0:
            raise ChoreoError(f"{self.robot.name} has no site {name!r}")
        self._site_ids[name] = site
        return site

    # --- inverse kinematics -------------------------------------------------------------------

    def solve(
        self,
        goals: Sequence[SiteGoal],
        seed_deg: npt.ArrayLike,
        free: npt.ArrayLike | None = None,
    ) -> Solution:
        """Joint angles putting every goal's site where it asks, starting from ``seed_deg``;
        only the ``free`` joints move (default: all). The best attempt if none reaches."""
        sites = [self._checked_site(goal.site) for goal in goals]
        task = self._task(goals, sites)
        seed = np.clip(np.asarray(seed_deg, dtype=float), self.lower_deg, self.upper_deg)
        free_mask = np.ones(len(seed), bool) if free is None else np.asarray(free, bool)
        free_mask = free_mask & task.moves.any(axis=0)  # restarts must not stir the rest
        free_mask &= self._constrained(task)  # ... nor joints the task ignores
        first = self._descend(task, seed[None], free_mask, _ITERATIONS)
        if first.reached[0]:
            return self._measure(goals, sites, first.angles_deg[0])
        best, best_cost = first.angles_deg[0], first.cost[0]
        # restarts in rounds, nearer the seed first; the solution nearest the seed is kept
        for starts in np.split(self._restarts(seed, free_mask), _RESTARTS // _RESTARTS_AT_ONCE):
            tried = self._descend(task, starts, free_mask, _RESTART_ITERATIONS)
            if tried.reached.any():  # the arm stays on its branch
                return self._measure(goals, sites, _nearest_reached(tried, seed))
            if tried.cost.min() < best_cost:
                best, best_cost = tried.angles_deg[np.argmin(tried.cost)], tried.cost.min()
        # the best start may only have been slow to converge (folded poses are): polish it
        polished = self._descend(task, best[None], free_mask, _ITERATIONS, POLISH_PROGRESS)
        end = polished.angles_deg[0]
        if not polished.reached[0] and free_mask.any():
            # stopped short by a joint limit on its branch: the same pose with joints turned
            # the other way (an elbow up for an elbow down) starts the other branches
            mirrored = self._mirrored(end, free_mask)
            tried = self._descend(task, mirrored, free_mask, _ITERATIONS, POLISH_PROGRESS)
            if tried.reached.any():
                return self._measure(goals, sites, _nearest_reached(tried, seed))
        return self._measure(goals, sites, end)

    def _mirrored(self, end_deg: np.ndarray, free: np.ndarray) -> np.ndarray:
        """``end_deg`` with one free joint turned to the other side of zero, then two (at most
        ``_MIRRORED`` starts), inside the limits."""
        joints = np.flatnonzero(free)
        flips = [*combinations(joints, 1), *combinations(joints, 2)][:_MIRRORED]
        starts = np.tile(end_deg, (len(flips), 1))
        for row, flip in enumerate(flips):
            starts[row, list(flip)] *= -1
        return np.clip(starts, self.lower_deg, self.upper_deg)

    def _task(self, goals: Sequence[SiteGoal], sites: list[int]) -> Task:
        pitched = np.array([goal.pitch_deg is not None for goal in goals])
        pitch_deg = np.array(
            [goal.pitch_deg for goal in goals if goal.pitch_deg is not None], float
        )
        pitch = np.radians(pitch_deg)
        return Task(
            np.array(sites),
            self._moving(tuple(sites)),
            np.array([goal.position_mm for goal in goals], dtype=float) / 1000,
            pitched,
            pitch_deg,
            np.column_stack([np.cos(pitch), np.sin(pitch)]),
        )

    def _restarts(self, seed_deg: np.ndarray, free: np.ndarray) -> np.ndarray:
        """Fixed random starts (the same file always gives the same pose) for the free joints,
        drawn ever farther from the seed so that solutions near it are among them."""
        rng = np.random.default_rng(0)
        widening = np.minimum(1.0, 2 * np.arange(1, _RESTARTS + 1) / _RESTARTS)[:, None]
        spread = (self.upper_deg - self.lower_deg) * widening
        low = np.maximum(self.lower_deg, seed_deg - spread)
        drawn = rng.uniform(low, np.minimum(self.upper_deg, seed_deg + spread))
        return np.where(free, drawn, seed_deg)

    def _constrained(self, task: Task) -> np.ndarray:
        """Which joints move what the goals ask (a site's position, its pitch) anywhere: a
        column of the task Jacobian that is non-zero at one of a few random poses (a joint that
        moves it somewhere moves it almost everywhere). A wrist roll about a tool's own axis
        changes neither, so IK leaves it as it was."""
        key = (tuple(task.sites), tuple(task.pitched))
        if key not in self._constrained_joints:
            rng = np.random.default_rng(1)
            angles = rng.uniform(self.lower_deg, self.upper_deg, (3, len(self.lower_deg)))
            _, jacobian, _, _ = linearise(task, self._poses(task, np.radians(angles)))
            self._constrained_joints[key] = np.any(np.linalg.norm(jacobian, axis=1) > 1e-6, axis=0)
        return self._constrained_joints[key]

    def _descend(
        self,
        task: Task,
        start_deg: np.ndarray,
        free: np.ndarray,
        iterations: int,
        progress_needed: float | None = None,
    ) -> Attempts:
        """``ik_descent.descend`` inside this robot's joint limits, posed on its model."""
        return descend(
            task,
            start_deg,
            free,
            iterations,
            (self.lower_deg, self.upper_deg),
            self._poses,
            progress_needed,
        )

    def _poses(self, task: Task, q_rad: np.ndarray) -> Poses:
        """The task's sites and Jacobians for joint vectors ``(N, joints)`` (radians): MuJoCo's
        forward kinematics, one vector at a time (a couple of microseconds each), and the
        Jacobians from the joints' axes and anchors, for all of them at once."""
        model, data, kinematics = self.model, self.data, self._mj.mj_kinematics
        n, qpos = len(q_rad), data.qpos
        rows = np.tile(qpos, (n, 1))  # whole rows copy faster than scattered joints
        rows[:, self._qpos] = q_rad
        positions, frames = np.empty((n, *data.site_xpos.shape)), np.empty((n, model.nsite, 9))
        axes, anchors = np.empty((n, *data.xaxis.shape)), np.empty((n, *data.xanchor.shape))
        for row in range(n):
            qpos[:] = rows[row]
            kinematics(model, data)
            positions[row], frames[row] = data.site_xpos, data.site_xmat
            axes[row], anchors[row] = data.xaxis, data.xanchor
        positions, frames = positions[:, task.sites], frames[:, task.sites]
        axes, anchors = axes[:, self._joint_ids], anchors[:, self._joint_ids]
        rotation = self._base_rot  # into the base frame: v @ R is R.T @ v for rows v
        positions = (positions - self._base_pos) @ rotation
        axes, anchors = axes @ rotation, (anchors - self._base_pos) @ rotation
        lever = positions[:, :, None, :] - anchors[:, None, :, :]  # (N, sites, joints, 3)
        moves = task.moves[None, :, :, None]
        velocity, turn = cross(axes[:, None], lever), axes[:, None]
        if not self._hinge.all():
            hinge = self._hinge[:, None]
            velocity, turn = np.where(hinge, velocity, turn), np.where(hinge, turn, 0.0)
        velocity, turn = velocity * moves, turn * moves
        return Poses(
            positions,
            frames[..., 2::3] @ rotation,  # the z column of each row-major 3x3
            np.swapaxes(velocity, 2, 3),
            np.swapaxes(turn, 2, 3),
        )

    def _moving(self, sites: tuple[int, ...]) -> np.ndarray:
        """Which robot joints move each site (rows): those on the way from it to the root."""
        if sites in self._moves:
            return self._moves[sites]
        moves = np.zeros((len(sites), len(self._joint_ids)), bool)
        for row, site in enumerate(sites):
            chain = set()
            body = int(self.model.site_bodyid[site])
            while body > 0:
                chain.add(body)
                body = int(self.model.body_parentid[body])
            moves[row] = [int(self.model.jnt_bodyid[j]) in chain for j in self._joint_ids]
        self._moves[sites] = moves
        return moves

    def _measure(self, goals: Sequence[SiteGoal], sites: list[int], q_deg: np.ndarray) -> Solution:
        """The verdict on a solution, from MuJoCo's own forward kinematics."""
        self._set(q_deg)
        reached, position_errors, pitch_errors = [], [], []
        for goal, site in zip(goals, sites):
            position, axis = self._site_in_base(site)
            pose = SitePose(position * 1000, pitch_deg(axis))
            reached.append(pose)
            position_errors.append(float(np.linalg.norm(pose.position_mm - goal.position_mm)))
            pitch_errors.append(
                0.0 if goal.pitch_deg is None else abs(pose.pitch_deg - goal.pitch_deg)
            )
        return Solution(q_deg, tuple(reached), tuple(position_errors), tuple(pitch_errors))


def _nearest_reached(attempts: Attempts, seed_deg: np.ndarray) -> np.ndarray:
    """Of the attempts that reached, the angles nearest the seed's: the arm stays on its
    branch."""
    distance = np.abs(attempts.angles_deg - seed_deg).max(axis=1)
    reached = np.flatnonzero(attempts.reached)
    return attempts.angles_deg[reached[np.argmin(distance[reached])]]
