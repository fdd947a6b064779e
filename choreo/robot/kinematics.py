"""Forward and inverse kinematics of a robot's named sites, on its MuJoCo model.

    kin = Kinematics(robot)
    kin.site_pose("tool", angles_deg)                    # where the tool is: mm, base frame
    solution = kin.solve([SiteGoal("tool", (160, 0, 40), pitch_deg=-80)], seed_deg)

Positions are in millimetres in the robot's base frame (the first body of its MJCF: an arm's
base, a walker's torso, held where the model's ``home`` keyframe puts it). A site's pitch is the
elevation of its z axis (its approach direction) above the base frame's horizontal plane:
+90 points up, -90 straight down.

IK is damped least squares on ``mj_jacSite``, inside the robot's joint limits (a joint at a limit
that the step would push further drops out of the step), seeded by the caller (the previous
keyframe), with fixed random restarts if the seed gets stuck: restarts drawn ever farther from the
seed, of which the reaching solution nearest the seed is kept (so a small move in space stays a
small move in joints), and joints the goals do not constrain stay where they were. ``mujoco`` is
imported here only when a ``Kinematics`` is made: motions without Cartesian keyframes never load
it. (mink, a QP
IK library on MuJoCo, would also do, but needs qpsolvers and a QP solver; these tasks — site
positions, one axis' elevation, joint limits — are small enough for damped least squares.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from choreo.errors import ChoreoError
from choreo.robot.types import Robot

POSITION_TOLERANCE_MM = 0.5  # a solution this close (and within the angle tolerance) is reached
ANGLE_TOLERANCE_DEG = 0.5
_CONVERGED_MM, _CONVERGED_DEG = 0.02, 0.02
_ITERATIONS = 400
_RESTARTS = 60  # random starts (fewer iterations each) when the seed gets stuck
_RESTART_ITERATIONS = 60
_SOLUTIONS_COMPARED = 3  # restarts that reach the goal, of which the nearest the seed is kept
_DAMPING = 1e-4
_MAX_STEP_RAD = 0.3
_POSITION_WEIGHT = 10.0  # residual rows: metres x 10 (1 mm ~ 0.01) next to radians (1° ~ 0.017)
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
        self.robot = robot
        self.model = mj.MjModel.from_xml_path(str(robot.mjcf_path))
        self.data = mj.MjData(self.model)
        home = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_KEY, "home")
        if home >= 0:
            mj.mj_resetDataKeyframe(self.model, self.data, home)
        joint_ids = [
            mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_JOINT, j.mjcf_joint) for j in robot.joints
        ]
        self._joint_ids = joint_ids
        self._qpos = np.array([self.model.jnt_qposadr[i] for i in joint_ids])
        self._dof = np.array([self.model.jnt_dofadr[i] for i in joint_ids])
        self.lower_deg = np.array([j.limits.min_deg for j in robot.joints], dtype=float)
        self.upper_deg = np.array([j.limits.max_deg for j in robot.joints], dtype=float)
        self._base = 1  # the robot's first body; IK holds it (and any free joint) in place
        mj.mj_kinematics(self.model, self.data)
        self._base_pos = self.data.xpos[self._base].copy()
        self._base_rot = self.data.xmat[self._base].reshape(3, 3).copy()
        self._jacp = np.zeros((3, self.model.nv))
        self._jacr = np.zeros((3, self.model.nv))

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
        self._mj.mj_comPos(self.model, self.data)  # the Jacobians need the dof frames

    def _site_in_base(self, site: int) -> tuple[np.ndarray, np.ndarray]:
        """(position m, z axis) of a site in the base frame, for the joints last set."""
        position = self._base_rot.T @ (self.data.site_xpos[site] - self._base_pos)
        axis = self._base_rot.T @ self.data.site_xmat[site].reshape(3, 3)[:, 2]
        return position, axis

    def site_pose(self, site: str, angles_deg: npt.ArrayLike) -> SitePose:
        self._set(np.asarray(angles_deg, dtype=float))
        position, axis = self._site_in_base(self._checked_site(site))
        return SitePose(position * 1000, _pitch_deg(axis))

    def _checked_site(self, name: str) -> int:
        site = self.site_id(name)
        if site < 0:
            raise ChoreoError(f"{self.robot.name} has no site {name!r}")
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
        seed = np.clip(np.asarray(seed_deg, dtype=float), self.lower_deg, self.upper_deg)
        free_mask = np.ones(len(seed), bool) if free is None else np.asarray(free, bool)
        free_mask = free_mask & self._moving(sites)  # restarts must not stir unrelated joints
        free_mask &= self._constrained(goals, sites, seed)  # ... nor joints the task ignores
        best = self._descend(goals, sites, seed, free_mask, _ITERATIONS)
        if best.ok:
            return best
        rng = np.random.default_rng(0)  # fixed restarts: the same file always gives the same pose
        reached: list[Solution] = []
        span = self.upper_deg - self.lower_deg
        for k in range(_RESTARTS):
            # restarts widen from the seed outwards, so the first solutions found are near it
            spread = span * min(1.0, 2 * (k + 1) / _RESTARTS)
            restart = seed.copy()
            low = np.maximum(self.lower_deg, seed - spread)
            drawn = rng.uniform(low, np.minimum(self.upper_deg, seed + spread))
            restart[free_mask] = drawn[free_mask]
            attempt = self._descend(goals, sites, restart, free_mask, _RESTART_ITERATIONS)
            if attempt.ok:
                reached.append(attempt)
                if len(reached) >= _SOLUTIONS_COMPARED:
                    break
            elif _cost(attempt) < _cost(best):
                best = attempt
        if reached:  # the solution nearest the seed: the arm stays on its branch
            return min(reached, key=lambda s: float(np.abs(s.angles_deg - seed).max()))
        # the best restart may only have been slow to converge (folded poses are): polish it
        polished = self._descend(goals, sites, best.angles_deg, free_mask, _ITERATIONS)
        return polished if _cost(polished) < _cost(best) else best

    def _constrained(
        self, goals: Sequence[SiteGoal], sites: list[int], seed_deg: np.ndarray
    ) -> np.ndarray:
        """Which joints move what the goals ask (a site's position, its pitch) anywhere: a
        column of the task Jacobian that is non-zero at the seed or at a few other poses. A
        wrist roll about a tool's own axis changes neither, so IK leaves it as it was."""
        rng = np.random.default_rng(1)
        constrained = np.zeros(len(seed_deg), bool)
        for angles in (seed_deg, *rng.uniform(self.lower_deg, self.upper_deg, (2, len(seed_deg)))):
            self._set(angles)
            _, jacobian, _ = self._linearise(goals, sites)
            constrained |= np.linalg.norm(jacobian, axis=0) > 1e-6
        return constrained

    def _moving(self, sites: list[int]) -> np.ndarray:
        """Which robot joints move any of ``sites``: those on the way from a site to the root."""
        chain = set()
        for site in sites:
            body = int(self.model.site_bodyid[site])
            while body > 0:
                chain.add(body)
                body = int(self.model.body_parentid[body])
        return np.array([int(self.model.jnt_bodyid[j]) in chain for j in self._joint_ids])

    def _descend(
        self,
        goals: Sequence[SiteGoal],
        sites: list[int],
        start_deg: np.ndarray,
        free: np.ndarray,
        iterations: int,
    ) -> Solution:
        q = np.radians(start_deg)
        low, high = np.radians(self.lower_deg), np.radians(self.upper_deg)
        for _ in range(iterations):
            self._set(np.degrees(q))
            residual, jacobian, done = self._linearise(goals, sites)
            if done:
                break
            step = _limited_step(jacobian[:, free], residual, q[free], low[free], high[free])
            q[free] = np.clip(q[free] + step, low[free], high[free])
        angles_deg = start_deg.copy()  # held joints exactly as given, not via radians
        angles_deg[free] = np.degrees(q[free])
        return self._measure(goals, sites, angles_deg)

    def _linearise(
        self, goals: Sequence[SiteGoal], sites: list[int]
    ) -> tuple[np.ndarray, np.ndarray, bool]:
        """Stacked weighted residual and Jacobian (robot joint columns); done if converged."""
        rows, jac_rows, done = [], [], True
        base_t = self._base_rot.T
        for goal, site in zip(goals, sites):
            position, axis = self._site_in_base(site)
            self._mj.mj_jacSite(self.model, self.data, self._jacp, self._jacr, site)
            jacp = base_t @ self._jacp[:, self._dof]
            error = np.asarray(goal.position_mm) / 1000 - position
            done &= bool(np.linalg.norm(error) * 1000 <= _CONVERGED_MM)
            rows.append(_POSITION_WEIGHT * error)
            jac_rows.append(_POSITION_WEIGHT * jacp)
            if goal.pitch_deg is not None:
                target = _axis_with_pitch(axis, position, goal.pitch_deg)
                jacr = base_t @ self._jacr[:, self._dof]
                rows.append(target - axis)
                jac_rows.append(np.cross(jacr.T, axis).T)  # d(axis)/dq = omega x axis
                done &= abs(_pitch_deg(axis) - goal.pitch_deg) <= _CONVERGED_DEG
        return np.concatenate(rows), np.vstack(jac_rows), done

    def _measure(self, goals: Sequence[SiteGoal], sites: list[int], q_deg: np.ndarray) -> Solution:
        self._set(q_deg)
        reached, position_errors, pitch_errors = [], [], []
        for goal, site in zip(goals, sites):
            position, axis = self._site_in_base(site)
            pose = SitePose(position * 1000, _pitch_deg(axis))
            reached.append(pose)
            position_errors.append(float(np.linalg.norm(pose.position_mm - goal.position_mm)))
            pitch_errors.append(
                0.0 if goal.pitch_deg is None else abs(pose.pitch_deg - goal.pitch_deg)
            )
        return Solution(q_deg, tuple(reached), tuple(position_errors), tuple(pitch_errors))


def _limited_step(
    jacobian: np.ndarray, residual: np.ndarray, q: np.ndarray, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """A damped least-squares step; joints at a limit it would push past are held out."""
    active = np.ones(len(q), bool)
    step = np.zeros(len(q))
    for _ in range(3):
        j = jacobian[:, active]
        step[:] = 0.0
        step[active] = j.T @ np.linalg.solve(j @ j.T + _DAMPING * np.eye(len(residual)), residual)
        blocked = ((q <= low + 1e-9) & (step < 0)) | ((q >= high - 1e-9) & (step > 0))
        if not (blocked & active).any():
            break
        active &= ~blocked
    largest = np.abs(step).max(initial=0.0)
    return step * (_MAX_STEP_RAD / largest) if largest > _MAX_STEP_RAD else step


def _pitch_deg(axis: np.ndarray) -> float:
    return float(np.degrees(np.arcsin(np.clip(axis[2], -1.0, 1.0))))


def _axis_with_pitch(axis: np.ndarray, position: np.ndarray, pitch_deg: float) -> np.ndarray:
    """The unit vector at ``pitch_deg`` elevation nearest ``axis``: same heading, or, when the
    axis is (nearly) vertical, heading away from the base axis towards the site."""
    heading = np.array([axis[0], axis[1], 0.0])
    if np.linalg.norm(heading) < 0.05:
        heading = np.array([position[0], position[1], 0.0])
    norm = np.linalg.norm(heading)
    heading = heading / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    pitch = np.radians(pitch_deg)
    return np.cos(pitch) * heading + np.array([0.0, 0.0, np.sin(pitch)])


def _cost(solution: Solution) -> float:
    return sum(solution.position_error_mm) + sum(solution.pitch_error_deg)
