"""Posing the robot in the studio: the sliders' pose (``Posing``, the studio's part that owns it),
set by a slider, a named pose, a mirror, the ring of a joint picked by a click on its link, or a
drag handle solved by the project's IK (an arm's sites, a free-standing robot's hands and feet,
a walker's body). A drag that cannot be done is refused; its handle goes back onto the robot
when let go.

The body's drag handle of a legged robot: the handle's move made into the ``body:`` pose a
motion file writes (mm and degrees, rounded as written) and the legs' angles that pose means,
solved as a ``body:`` keyframe is (``choreo.motion.spatial``): every foot kept where it stands.

A pose is a transform of the body from where it stood: ``p_before = R p_after + t``
(``BodyPose.rotation()`` is ``R``, its x, y, z are ``t``), as ``feet_under_body`` reads it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from choreo.motion.gait import BodyPose, feet_under_body
from choreo.play.recorder import limit_problems
from choreo.robot.kinematics import Kinematics, SiteGoal, Solution
from choreo.robot.poses import HOME_POSE
from choreo.robot.types import mirror_pose
from choreo.studio.parts import StudioParts
from choreo.studio.scene import rotation_of
from choreo.studio.session import Plan
from choreo.studio.yaml_edit import number


@dataclass(frozen=True)
class BodyDrag:
    """A drag of the body's handle, from where it began: the handle then (world, m), the
    ``body:`` pose the robot was in, the feet's stance (the angles that planted them) and the
    angles the legs are solved from (as the keyframe before seeds a ``body:`` keyframe)."""

    handle_m: np.ndarray  # (3,)
    handle_rotation: np.ndarray  # (3, 3)
    start: BodyPose
    stance_deg: np.ndarray
    seed_deg: np.ndarray


def pose_of(rotation: np.ndarray, offset_mm: np.ndarray) -> BodyPose:
    """The ``BodyPose`` of a transform, rounded as a motion file gets it: ``rotation`` is
    ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = np.arcsin(np.clip(-rotation[2, 0], -1.0, 1.0))
    roll = np.arctan2(rotation[2, 1], rotation[2, 2])
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    x, y, z = (float(number(v)) for v in offset_mm)
    roll_deg, pitch_deg, yaw_deg = (float(number(np.degrees(a))) for a in (roll, pitch, yaw))
    return BodyPose(x, y, z, roll_deg, pitch_deg, yaw_deg)


def pose_after(drag: BodyDrag, handle_m: np.ndarray, handle_wxyz: npt.ArrayLike) -> BodyPose:
    """The body's pose once the handle moved from where the drag began to ``handle_m`` turned
    to ``handle_wxyz``: the drag's own move (in the body's frame) after the pose it began in."""
    turn = drag.handle_rotation.T @ rotation_of(handle_wxyz)
    shift_mm = drag.handle_rotation.T @ (np.asarray(handle_m, dtype=float) - drag.handle_m) * 1000
    start = drag.start
    rotation = start.rotation()
    offset = np.array([start.x_mm, start.y_mm, start.z_mm])
    return pose_of(rotation @ turn, rotation @ shift_mm + offset)


def solve_body(kinematics: Kinematics, feet: Sequence[str], drag: BodyDrag, pose: BodyPose):
    """The legs' angles with the body at ``pose`` and every foot where the stance put it."""
    stance_mm = np.array([kinematics.site_pose(foot, drag.stance_deg).position_mm for foot in feet])
    goals = [
        SiteGoal(foot, (float(x), float(y), float(z)))
        for foot, (x, y, z) in zip(feet, feet_under_body(stance_mm, pose))
    ]
    return kinematics.solve(goals, drag.seed_deg)


def farthest_foot(feet: Sequence[str], solution: Solution) -> tuple[str, float]:
    """The foot a pose out of reach misses most, and by how many mm."""
    worst = int(np.argmax(solution.position_error_mm))
    return feet[worst], float(solution.position_error_mm[worst])


def site_pitch(plan: Plan, site: str, t_s: float) -> float | None:
    """The pitch the last keyframe reached by ``t_s`` that places ``site`` gives it (None:
    none does, or it leaves the pitch free)."""
    keyframes = plan.motion.keyframes
    reached = [i for i, t in enumerate(plan.keyframe_times_s) if t <= t_s + 1e-9]
    for i in reversed(reached):
        for target in keyframes[i].sites:
            if target.site == site:
                return target.pitch_deg
    return None


class LatestOnly:
    """Calls ``handle`` with the newest arguments, dropping those that came while it ran: a drag
    sends dozens of moves a second from viser's threads, and a slow solve (a pose out of reach
    tries many) must neither queue them nor let an older one land after a newer one."""

    def __init__(self, handle: Callable[..., None]):
        self._handle = handle
        self._guard = threading.Lock()
        self._pending: tuple | None = None
        self._busy = False

    def __call__(self, *args) -> None:
        with self._guard:
            self._pending = args
            if self._busy:
                return  # the call under way takes these next
            self._busy = True
        try:
            while True:
                with self._guard:
                    newest, self._pending = self._pending, None
                    if newest is None:
                        self._busy = False
                        return
                self._handle(*newest)
        except BaseException:
            with self._guard:
                self._busy = False
            raise


class Posing(StudioParts):
    """The sliders' pose (``posing``, None: the plan's) and what made it: a slider, a named
    pose, a mirror, a site's handle (``site_goal``) or the body's (``body_goal``)."""

    def _init_posing(self) -> None:
        self.posing = None
        self.site_goal = None
        self.body_goal = None
        self._body_drag: BodyDrag | None = None  # from where the body's handle began
        self._posed_root = None  # where the body's handle put the body
        self._feet: tuple[str, ...] = ()
        self._kinematics: Kinematics | None = None

    def move_joint(self, name: str, value: object) -> None:
        with self._lock:
            self._set_joint(name, value)

    def _set_joint(self, name: str, value: object) -> bool:
        """Joint ``name`` of the sliders' pose at ``value`` degrees; False, with a refusal, for
        a joint the robot lacks or an angle outside its limits."""
        plan = self._plan()
        if plan is None:
            return False
        robot = plan.motion.robot
        try:
            joint, angle = robot.joint(name), float(value)  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError):
            self.refuse(f"refused: joint {name!r} = {value!r} is not a joint and an angle")
            return False
        if not joint.limits.contains(angle):
            self.refuse(
                f"refused: {name} {angle:g}° is outside its limits {joint.limits.range_text}"
            )
            self.page.show_joints(self._pose())
            return False
        pose = self._pose()
        pose[robot.joint_names.index(name)] = angle
        self._set_pose(pose, plan)
        return True

    def pick_joint(self, origin_m: np.ndarray, direction: np.ndarray) -> None:
        """A click in the 3D view along the ray from ``origin_m``: on a link, a ring to turn
        the joint that turns it; elsewhere, no ring."""
        with self._lock:
            plan = self._plan()
            if self.view is None or plan is None:
                return
            joint = self.view.joint_at(origin_m, direction)
            if joint is None:
                self.view.remove_joint_handle()
                return
            self.view.add_joint_handle(joint, LatestOnly(self.turn_joint))
            limits = plan.motion.robot.joints[joint].limits
            self.note(
                f"turning {plan.motion.robot.joints[joint].name}: drag its ring "
                f"(within {limits.range_text})"
            )

    def turn_joint(self, name: str, wxyz: np.ndarray) -> None:
        """The picked joint at the angle its ring was turned to. Turned past a limit, the joint
        stops at that limit, as a hand-turned joint would, with a line saying so; the ring goes
        back onto the joint when let go."""
        with self._lock:
            plan = self._plan()
            if self.view is None or plan is None or name not in plan.motion.robot.joint_names:
                self.refuse(f"refused: no joint {name!r} to turn")
                return
            if not np.all(np.isfinite(wxyz)) or np.linalg.norm(wxyz) < 1e-9:
                self.refuse(f"refused: {wxyz} is not a rotation")
                return
            index = plan.motion.robot.joint_names.index(name)
            angle = round(self.view.turned_deg(index, wxyz), 1)
            limits = plan.motion.robot.joints[index].limits
            if limits.contains(angle):
                self._set_joint(name, angle)
                return
            # the limit on the side the joint stands: the ring's angle wraps at ±180°, so the
            # one nearer the asked angle may be across the joint's whole range
            now = float(self._pose()[index])
            limit = min((limits.min_deg, limits.max_deg), key=lambda end: abs(end - now))
            if now != limit:
                self.note(
                    f"{name} stops at its limit {limit:g}° (the ring was turned to {angle:g}°)"
                )
                self._set_joint(name, limit)

    def take_pose(self, name: str) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            if name not in plan.motion.robot.poses:
                self.refuse(f"refused: the robot has no pose {name!r}")
                return
            self._set_pose(np.array(plan.motion.robot.pose_vector(name)), plan)

    def take_angles(self, angles_deg: Mapping[str, float]) -> bool:
        """The sliders take ``angles_deg`` (joint -> degrees; the joints not named keep
        theirs); False, with a refusal, for a joint the robot lacks or an angle out of limits."""
        with self._lock:
            plan = self._plan()
            if plan is None:
                return False
            robot = plan.motion.robot
            unknown = sorted(set(angles_deg) - set(robot.joint_names))
            if unknown:
                self.refuse(f"refused: {robot.name} has no joint {', '.join(unknown)}")
                return False
            pose = [angles_deg.get(n, a) for n, a in zip(robot.joint_names, self._pose())]
            problems = limit_problems(robot, pose)
            if problems:
                self.refuse("refused: " + "; ".join(problems))
                return False
            self._set_pose(np.array(pose, dtype=float), plan)
            return True

    def mirror(self) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            robot = plan.motion.robot
            current = dict(zip(robot.joint_names, self._pose()))
            mirrored = {**current, **mirror_pose(robot, current)}
            self._set_pose(np.array([mirrored[n] for n in robot.joint_names]), plan)

    def _add_site_handles(self, plan: Plan) -> None:
        """Handles for an arm's sites, for the body of a robot whose MJCF names its feet
        (the robots ``body:`` keyframes are written for), or for a free-standing robot's
        limbs (a humanoid's hands and feet: one site per limb)."""
        robot = plan.motion.robot
        self._kinematics = None
        if robot.mjcf_path is None or self.view is None:
            return
        self._kinematics = Kinematics(robot)
        self._feet = self._kinematics.feet() if robot.free_floating else ()
        if self._feet:
            self.view.add_body_handle(LatestOnly(self.drag_body))
            return
        if robot.free_floating:
            sites = list(self.view.limb_sites())
        else:
            sites = [n for n in self._kinematics.site_names if n]
        self.view.add_site_handles(sites, LatestOnly(self.drag_site))

    def drag_site(self, site: str, world_m: np.ndarray) -> None:
        """Solve the pose putting ``site`` at ``world_m`` with the project's IK (as a ``sites:``
        keyframe is solved), the joints not on its way staying as they are, and the site
        pitched as the last keyframe that placed it wrote (a ``sites:`` keyframe keeps it)."""
        with self._lock:
            plan, kinematics = self._plan(), self._kinematics
            if plan is None or kinematics is None or not np.all(np.isfinite(world_m)):
                self.refuse(f"refused: no site {site!r} to move to {world_m}")
                return
            assert self.view is not None
            base_m, base_rotation = self.view.body_frame(kinematics.base_body)
            x, y, z = (float(v) for v in base_rotation.T @ (world_m - base_m) * 1000)
            goal = SiteGoal(site, (x, y, z), site_pitch(plan, site, self.time_s))
            solution = kinematics.solve([goal], self._pose())
            if not solution.ok:
                self.refuse(
                    f"refused: {site} cannot reach there: the nearest pose is "
                    f"{solution.position_error_mm[0]:.0f} mm away; the last pose that works stays"
                )
                return
            self._set_pose(np.array(solution.angles_deg), plan, goal)

    def drag_body(self, world_m: np.ndarray, wxyz: np.ndarray) -> None:
        """Move the body to where its handle is, feet planted: the legs solved by the project's
        IK as a ``body:`` keyframe is; a pose out of the legs' reach is refused."""
        with self._lock:
            plan, kinematics = self._plan(), self._kinematics
            finite = np.all(np.isfinite(world_m)) and np.all(np.isfinite(wxyz))
            if plan is None or kinematics is None or not self._feet or not finite:
                self.refuse(f"refused: no body to move to {world_m} {wxyz}")
                return
            if np.linalg.norm(wxyz) < 1e-9:
                self.refuse(f"refused: {wxyz} is not a rotation")
                return
            drag = self._body_drag or self._begin_body_drag(plan)
            if drag is None:
                return
            pose = pose_after(drag, world_m, wxyz)
            solution = solve_body(kinematics, self._feet, drag, pose)
            if not solution.ok:
                foot, miss_mm = farthest_foot(self._feet, solution)
                self.refuse(
                    f"refused: the body cannot go there: foot {foot} would end {miss_mm:.0f} mm "
                    "from where it stands (out of the leg's reach); the last pose "
                    "that works stays"
                )
                return
            root = (np.array(world_m, dtype=float), np.array(wxyz, dtype=float))
            self._set_pose(np.array(solution.angles_deg), plan, body=(drag, pose, root))

    def _begin_body_drag(self, plan: Plan) -> BodyDrag | None:
        """The body is posed from the feet the keyframes planted: those of the last keyframe
        reached by the timeline's time that is not a ``body:`` keyframe itself."""
        assert self.view is not None
        keyframes = plan.motion.keyframes
        reached = [i for i, t in enumerate(plan.keyframe_times_s) if t <= self.time_s + 1e-9]
        if not reached:
            self.refuse("refused: the body is posed from a keyframe: scrub to one first")
            return None
        last = reached[-1]
        planted = [i for i in range(last + 1) if keyframes[i].body is None]
        robot = plan.motion.robot
        stance = keyframes[planted[-1]].targets_deg if planted else robot.pose_vector(HOME_POSE)
        position, wxyz = self.view.root_pose()
        return BodyDrag(
            handle_m=position,
            handle_rotation=rotation_of(wxyz),
            start=keyframes[last].body or BodyPose(),
            stance_deg=np.array(stance, dtype=float),
            seed_deg=np.array(keyframes[last].targets_deg, dtype=float),
        )

    def follow_plan(self) -> None:
        self.scrub(self.time_s)

    def _pose(self) -> np.ndarray:
        plan = self._plan()
        if self.posing is not None:
            return self.posing.copy()
        return plan.posed_deg(self.time_s) if plan else np.zeros(0)

    def _back_to_the_plan(self) -> None:
        self._set_pose(None)

    def _set_pose(
        self,
        pose: np.ndarray | None,
        plan: Plan | None = None,
        site_goal: SiteGoal | None = None,
        body: tuple[BodyDrag, BodyPose, tuple[np.ndarray, np.ndarray]] | None = None,
    ) -> None:
        """The sliders' pose (None: the plan's) and what made it: a site's handle
        (``site_goal``), or the body's (``body``: the drag, the pose, where the body is)."""
        self.posing, self.site_goal = pose, site_goal
        self._body_drag, self.body_goal, self._posed_root = body or (None, None, None)
        if pose is None or plan is None:
            return
        self.page.show_joints(pose)
        self._redraw(plan)
