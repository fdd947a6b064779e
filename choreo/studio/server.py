"""The studio: one motion file, one viser server, every tab showing the same state.

Threads: viser calls the page's callbacks from its own threads, the file watcher and the player
run in theirs; ``Studio._lock`` makes each change of state whole (a reload never interleaves with
an edit or a redraw).
"""

from __future__ import annotations

import contextlib
import io
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from choreo.core.atomic import write_text_atomically
from choreo.errors import ChoreoError, SourceError
from choreo.motion.gait import BodyPose
from choreo.motion.motion_file import Motion, load_motion
from choreo.play.recorder import limit_problems
from choreo.robot.kinematics import Kinematics, SiteGoal
from choreo.robot.types import mirror_pose
from choreo.studio import require, yaml_edit
from choreo.studio.address import Address
from choreo.studio.live import LiveRobot
from choreo.studio.page import SPEEDS, Page
from choreo.studio.posing import BodyDrag, farthest_foot, pose_after, rotation_of, solve_body
from choreo.studio.scene import RobotView
from choreo.studio.session import Plan, Reload, Session
from choreo.studio.timeline_page import Timeline, keyframe_of
from choreo.studio.watch import FileWatcher

FRAME_S = 1 / 30  # the player redraws the page at 30 frames a second
TIME_SLACK_S = 0.01  # the timeline's ends are shown rounded to its step
BODY_MATCH_DEG = 0.5  # a body: keyframe as loaded may be this far from the pose the handle made
# what the page hears when it asks for the robot of a studio given none (its controls are hidden)
NO_ROBOT = "refused: no robot: this studio was started without one to drive"


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


class Studio:
    """``start`` serves the page and follows the files; ``close`` stops it all."""

    def __init__(
        self,
        motion_path: Path,
        listen: Address,
        say: Callable[[str], None],
        live: LiveRobot | None = None,
    ):
        viser = require("viser")
        self.session = Session(Path(motion_path))
        self._say = say
        self._lock = threading.RLock()
        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: the CLI says the URL
            self.server = viser.ViserServer(host=listen.host, port=listen.port, verbose=False)
        # The page's "share" asks viser's relay for a public URL: never, this page writes files.
        self.server.request_share_url = lambda *args, **kwargs: None
        self.address = Address(listen.host, self.server.get_port())
        self.live = live
        self.driving = False  # the live robot follows the page
        self.timeline = Timeline(listen.host, self)
        self._status: tuple[str, str] = ("loading…", "")  # the files' state, and its kind
        self._last_note: tuple[str, str] = ("", "")  # what the last action did, and its kind
        self.page = Page(self.server, self, live=live is not None, timeline_port=self.timeline.port)
        self.server.on_client_disconnect(self._tab_closed)
        self.view: RobotView | None = None
        self.time_s = 0.0
        self.playing = False
        self.speed = 1.0
        self.posing: np.ndarray | None = None  # the sliders' pose, once a slider moved
        self.selected: int | None = None  # the selected keyframe (index into motion.keyframes)
        # the site a drag handle put the robot's pose for (base frame mm): captured as sites:
        self.site_goal: tuple[str, np.ndarray] | None = None
        # a legged robot's body pose the body's handle made, feet planted: captured as body:
        self.body_goal: BodyPose | None = None
        self._body_drag: BodyDrag | None = None  # from where the body's handle began
        self._posed_root: tuple[np.ndarray, np.ndarray] | None = None  # where it put the body
        self._feet: tuple[str, ...] = ()
        self._kinematics: Kinematics | None = None
        self._stop = threading.Event()
        self._watcher = FileWatcher(lambda: self.session.watched_files, self.reload)
        self._player = threading.Thread(target=self._play_loop, name="studio-play", daemon=True)

    # --- life ----------------------------------------------------------------------------------

    def start(self) -> None:
        self.timeline.start()
        self.reload()
        self._watcher.start()
        self._player.start()

    def close(self) -> None:
        if self.live is not None:
            self.live.close()
        self._stop.set()
        self._watcher.stop()
        self.timeline.close()
        if self._player.is_alive():
            self._player.join(timeout=2.0)
        with contextlib.redirect_stdout(io.StringIO()):  # viser's "Server stopped"
            self.server.stop()

    def wait(self) -> None:
        """Until ``close`` (another thread) or Ctrl-C."""
        while not self._stop.wait(0.2):
            pass

    # --- the files -----------------------------------------------------------------------------

    def reload(self) -> None:
        """Load and plan the files and show the plan at once; then simulate it (the page stays
        live meanwhile) and show what the physics did."""
        with self._lock:
            result = self.session.reload()
            self._show_reload(result)
        if not result.problems:
            simulated = self.session.simulate(result.version)
            if simulated is not None:
                with self._lock:
                    self._show_reload(simulated)

    def _show_reload(self, result: Reload) -> None:
        for problem in result.problems:
            self._say(problem)
        self.page.show_problems(result.problems)
        plan = self.session.plan
        self._show_status(reload_status(result, plan))
        if plan is None:
            return
        motion = plan.motion
        if not result.problems:
            done = "simulated" if plan.physics is not None else "planned"
            self._say(f"{done} {motion.path}: {plan.end_s:.2f} s, reload {result.version}")
        if self.view is None or not self.view.matches(motion.robot, motion.props):
            self.server.scene.reset()
            self.view = RobotView(self.server, motion.robot, motion.props)
            self._kinematics = None
            self._add_site_handles(plan)
        self.page.show_plan(plan)
        self.timeline.show_plan(plan, result.version, self.view.limbs())
        if self.selected is not None and self.selected >= len(motion.keyframes):
            self.selected = None
        self.time_s = float(np.clip(self.time_s, plan.start_s, plan.end_s))
        self._redraw(plan)
        if self.posing is None:
            self.page.show_joints(plan.planned_deg(self.time_s))

    def _plan(self) -> Plan | None:
        return self.session.plan

    # --- the timeline --------------------------------------------------------------------------

    def scrub(self, t_s: float) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            if not plan.start_s - TIME_SLACK_S <= t_s <= plan.end_s + TIME_SLACK_S:
                self.refuse(
                    f"refused: t {t_s:g} s is outside the timeline "
                    f"{plan.start_s:.2f}..{plan.end_s:.2f} s"
                )
                return
            self.time_s = self._snapped(plan, float(np.clip(t_s, plan.start_s, plan.end_s)))
            self._back_to_the_plan()
            self._redraw(plan)
            self.page.show_joints(plan.planned_deg(self.time_s))
            if self.playing:  # the pages' clocks go on from here
                self.timeline.show_play(True, self.time_s, self.speed)

    def _snapped(self, plan: Plan, t_s: float) -> float:
        """``t_s``, or with "snap to beats" the nearest beat of the music."""
        music = plan.motion.music
        if music is None or not self.page.snap.value or t_s < music.grid.beat_times_s[0]:
            return t_s
        grid = music.grid
        return grid.time_of(min(max(round(grid.beat_at(t_s)), 1), grid.beats))

    def toggle_play(self) -> None:
        with self._lock:
            self.playing = not self.playing
            self.page.play.label = "Pause" if self.playing else "Play"
            if self.playing:
                self._back_to_the_plan()
            self.timeline.show_play(self.playing, self.time_s, self.speed)
            if not self.playing:
                self._redraw_current()

    def set_speed(self, text: str) -> None:
        if text not in SPEEDS:
            self.refuse(f"refused: speed {text!r} is not one of {', '.join(SPEEDS)}")
            return
        with self._lock:
            self.speed = float(text)
            if self.playing:
                self.timeline.show_play(True, self.time_s, self.speed)

    def show_ghost(self, visible: bool) -> None:
        with self._lock:
            if self.view is not None:
                self.view.ghost_visible = visible
            self._redraw_current()

    def _play_loop(self) -> None:
        last = time.monotonic()
        while not self._stop.wait(FRAME_S):
            now = time.monotonic()
            elapsed, last = now - last, now
            with self._lock:
                plan = self._plan()
                if not self.playing or plan is None:
                    continue
                self.time_s += elapsed * self.speed
                if self.time_s > plan.end_s:
                    self.time_s = plan.start_s
                    self.timeline.show_play(True, self.time_s, self.speed)
                self._redraw(plan)

    def _redraw_current(self) -> None:
        plan = self._plan()
        if plan is not None:
            self._redraw(plan)

    def _redraw(self, plan: Plan) -> None:
        if self.view is None:
            return
        t = self.time_s
        planned = plan.planned_deg(t)
        if plan.physics is not None:
            qpos = plan.physics.qpos_at(t)
        else:  # simulating: the robot takes the plan's pose where it stands
            qpos = self.view.qpos_with(self.view.qpos, planned)
        if self.posing is not None:
            self.view.show(self.view.qpos_with(qpos, self.posing, self._posed_root), planned)
        else:
            self.view.show(qpos, planned)
        self.page.show_time(t, self._time_text(plan, t))
        if not self.playing:  # while playing, each page keeps time with its own clock
            self.timeline.show_time(t)
        if self.driving and self.live is not None:
            self.live.follow(self.posing if self.posing is not None else planned)

    def _time_text(self, plan: Plan, t: float) -> str:
        phase = plan.phase(t)
        text = f"**{t:.2f} s** · {phase}"
        music = plan.motion.music
        if music is not None and t >= 0:
            bar, beat = music.grid.bar_and_beat(music.grid.beat_at(t))
            text += f" · bar {bar} beat {beat:.1f}"
        if self.posing is not None:
            text += " · posing (the sliders' pose; the ghost is the plan)"
        return text

    # --- keyframes and poses -------------------------------------------------------------------

    def select_keyframe(self, index: int | None) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None or index is None:
                self.selected = None
                return
            self.selected = index
            keyframe, t = plan.keyframe_at(index)
            values = ", ".join(
                f"{name} {angle:g}°"
                for name, angle in zip(plan.motion.robot.joint_names, keyframe.targets_deg)
            )
            label = f" ({keyframe.label})" if keyframe.label else ""
            self.page.show_keyframe(index, f"`{keyframe.where}`{label} at {t:.2f} s: {values}")
            self.scrub(t)

    def select_keyframes(self, indices: Sequence[int]) -> None:
        """The timeline's selection: one keyframe is the panel's too (Update, Move, Delete act
        on it); several, or none, leave the panel none."""
        with self._lock:
            plan = self._plan()
            count = len(plan.motion.keyframes) if plan is not None else 0
            if any(i >= count for i in indices):
                self.refuse(f"refused: the motion has {count} keyframes, not {max(indices) + 1}")
                return
            if len(indices) == 1:
                self.select_keyframe(indices[0])
            else:
                self.selected = None
                several = f"{len(indices)} keyframes selected" if indices else ""
                self.page.show_keyframe(None, several)

    def name_finding(self, index: int) -> None:
        """A finding clicked in the timeline: the playhead goes there and the status line says
        it with the keyframe it belongs to."""
        with self._lock:
            plan = self._plan()
            if plan is None or index >= len(plan.findings):
                self.refuse(f"refused: there is no finding {index + 1}")
                return
            finding = plan.findings[index]
            keyframe = plan.motion.keyframes[keyframe_of(plan.keyframe_times_s, finding.time_s)]
            self.scrub(finding.time_s)
            self.note(
                f"{finding.time_s:.2f} s {finding.severity.value}: {finding.message} "
                f"(keyframe at {keyframe.where})"
            )

    def move_keyframes(self, moves: Sequence[tuple[int, float]]) -> None:
        """Move keyframes (index, to time s) as Move keyframe here does, one after the other:
        the ones moving later from the last, those moving earlier from the first, so none
        passes another on the way; the first refusal stops the rest."""
        later = bool(moves) and moves[0][1] > self._keyframe_time(moves[0][0])
        for index, t_s in sorted(moves, reverse=later):
            version = self.session.version
            self.select_keyframe(index)
            self.scrub(t_s)
            self.retime_keyframe()
            if self.session.version == version:
                return

    def _keyframe_time(self, index: int) -> float:
        plan = self._plan()
        if plan is None or index >= len(plan.keyframe_times_s):
            return float("inf")
        return plan.keyframe_times_s[index]

    def delete_keyframes(self, indices: Sequence[int]) -> None:
        """Delete keyframes as Delete keyframe does, the last first (so the numbers of the
        others stay)."""
        for index in sorted(set(indices), reverse=True):
            version = self.session.version
            self.select_keyframe(index)
            self.delete_keyframe()
            if self.session.version == version:
                return

    def paste_keyframes(self, keyframes: Sequence[tuple[float, Mapping[str, float]]]) -> None:
        """Add copied poses (time s, joint -> degrees) as Add keyframe does, earliest first."""
        for t_s, pose in sorted(keyframes, key=lambda k: k[0]):
            version = self.session.version
            with self._lock:
                plan = self._plan()
                if plan is None:
                    return
                robot = plan.motion.robot
                unknown = sorted(set(pose) - set(robot.joint_names))
                if unknown:
                    self.refuse(f"refused: {robot.name} has no joint {', '.join(unknown)}")
                    return
                self.scrub(t_s)
                angles = [pose.get(name, a) for name, a in zip(robot.joint_names, self._pose())]
                problems = limit_problems(robot, angles)
                if problems:
                    self.refuse("refused: " + "; ".join(problems))
                    return
                self._set_pose(np.array(angles, dtype=float), plan)
            self.add_keyframe()
            if self.session.version == version:
                return

    def undo(self) -> None:
        self.refuse("refused: undo is not here yet")

    def redo(self) -> None:
        self.refuse("refused: redo is not here yet")

    def move_joint(self, name: str, value: object) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            robot = plan.motion.robot
            try:
                joint, angle = robot.joint(name), float(value)  # type: ignore[arg-type]
            except (KeyError, TypeError, ValueError):
                self.refuse(f"refused: joint {name!r} = {value!r} is not a joint and an angle")
                return
            if not joint.limits.contains(angle):
                self.refuse(
                    f"refused: {name} {angle:g}° is outside its limits {joint.limits.range_text}"
                )
                self.page.show_joints(self._pose())
                return
            pose = self._pose()
            pose[robot.joint_names.index(name)] = angle
            self._set_pose(pose, plan)

    def take_pose(self, name: str) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            if name not in plan.motion.robot.poses:
                self.refuse(f"refused: the robot has no pose {name!r}")
                return
            self._set_pose(np.array(plan.motion.robot.pose_vector(name)), plan)

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
        """Handles for an arm's sites, or for the body of a robot whose MJCF names its feet
        (the robots ``body:`` keyframes are written for)."""
        robot = plan.motion.robot
        if robot.mjcf_path is None or self.view is None:
            return
        self._kinematics = Kinematics(robot)
        self._feet = self._kinematics.feet() if robot.free_floating else ()
        if self._feet:
            self.view.add_body_handle(LatestOnly(self.drag_body))
        elif not robot.free_floating:
            sites = [n for n in self._kinematics.site_names if n]
            self.view.add_site_handles(sites, LatestOnly(self.drag_site))

    def drag_site(self, site: str, world_m: np.ndarray) -> None:
        """Solve the pose putting ``site`` at ``world_m`` with the project's IK (as a ``sites:``
        keyframe is solved), the joints not on its way staying as they are."""
        with self._lock:
            plan, kinematics = self._plan(), self._kinematics
            if plan is None or kinematics is None or not np.all(np.isfinite(world_m)):
                self.refuse(f"refused: no site {site!r} to move to {world_m}")
                return
            at_mm = kinematics.world_to_base_mm(world_m * 1000)
            solution = kinematics.solve([SiteGoal(site, tuple(at_mm))], self._pose())
            self._set_pose(np.array(solution.angles_deg), plan, (site, at_mm))
            if not solution.ok:
                self.note(
                    f"{site} cannot reach there: the nearest pose is "
                    f"{solution.position_error_mm[0]:.0f} mm away"
                )

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
        stance = keyframes[planted[-1]].targets_deg if planted else robot.pose_vector("home")
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
        return np.array(plan.planned_deg(self.time_s)) if plan else np.zeros(0)

    def _back_to_the_plan(self) -> None:
        self._set_pose(None)

    def _set_pose(
        self,
        pose: np.ndarray | None,
        plan: Plan | None = None,
        site_goal: tuple[str, np.ndarray] | None = None,
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

    # --- writing the file ----------------------------------------------------------------------

    def add_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            if self.time_s < 0:
                raise yaml_edit.EditRefused("the timeline is in the approach: pick a time >= 0")
            items = self._items(text, plan)
            before = [i for i, t in items if t <= self.time_s + 1e-9]
            after = max(before) if before else None
            new = yaml_edit.add_keyframe(text, after, *self._captured(plan), self._timing(plan))
            self._check_body(new, 0 if after is None else after + 1)
            return new

        self._edit(change, "added a keyframe")

    def update_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            item, where = self._selected_item(text, plan)
            new = yaml_edit.update_keyframe(text, item, where, *self._captured(plan))
            self._check_body(new, item)
            return new

        self._edit(change, "updated the keyframe")

    def _check_body(self, text: str, item: int) -> None:
        """A ``body:`` pose written as the ``item``-th keyframe of ``text`` must mean the pose on
        screen: the file moves the body from the feet the keyframes before it planted, and
        those must be the feet the handle kept (``EditRefused`` if not)."""
        if self.body_goal is None or self.posing is None:
            return
        motion = check_loads(self.session.motion_path, text)
        line = yaml_edit.keyframe_items(text)[item].content_line + 1
        written = [
            k.targets_deg
            for k in motion.keyframes
            if k.where.line == line and not k.where.included_at and k.body is not None
        ]
        if not written or np.abs(np.subtract(written[0], self.posing)).max() > BODY_MATCH_DEG:
            raise yaml_edit.EditRefused(
                "a body: keyframe there would stand on other feet than the pose shown (a body: "
                "pose moves the body from the feet the keyframes before it planted): scrub to "
                "the keyframe it follows, pose the body there, and add it"
            )

    def retime_keyframe(self) -> None:
        self._edit(
            lambda text, plan: yaml_edit.retime_keyframe(
                text, *self._selected_item(text, plan), self._timing(plan)
            ),
            "moved the keyframe",
        )

    def delete_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            item, _ = self._selected_item(text, plan)
            self.selected = None
            return yaml_edit.delete_keyframe(text, item)

        self._edit(change, "deleted the keyframe")

    def _captured(self, plan: Plan) -> tuple[str, object]:
        """What a keyframe captures: the site a handle placed (``sites:``), else every joint's
        angle (``pose:``)."""
        if self.site_goal is not None:
            site, at_mm = self.site_goal
            return "sites", yaml_edit.sites_mapping(site, at_mm)
        if self.body_goal is not None:
            return "body", yaml_edit.body_mapping(self.body_goal)
        pose = dict(zip(plan.motion.robot.joint_names, (float(a) for a in self._pose())))
        return "pose", yaml_edit.pose_mapping(pose)

    def _timing(self, plan: Plan) -> yaml_edit.Timing:
        """The timeline's time as a keyframe is written: in beats in a dance, else seconds."""
        music = plan.motion.music
        return yaml_edit.timing(self._file_t(plan), music.grid if music else None)

    def _file_t(self, plan: Plan) -> float:
        """The timeline's time as the file writes it (before the motion's speed)."""
        return self.time_s * plan.motion.speed

    def _items(self, text: str, plan: Plan) -> list[tuple[int, float]]:
        """(item index in the file's list, arrival time) of the keyframes written in the file."""
        items = yaml_edit.keyframe_items(text)
        by_line = {item.content_line + 1: i for i, item in enumerate(items)}
        own = self.session.motion_path.resolve()
        found = []
        for keyframe, t in zip(plan.motion.keyframes, plan.keyframe_times_s):
            where = keyframe.where
            if Path(where.path).resolve() == own and not where.included_at:
                if where.line in by_line:
                    found.append((by_line[where.line], t))
        return found

    def _selected_item(self, text: str, plan: Plan) -> tuple[int, str]:
        if self.selected is None:
            raise yaml_edit.EditRefused("select a keyframe first")
        keyframe = plan.motion.keyframes[self.selected]
        where = keyframe.where
        if Path(where.path).resolve() != self.session.motion_path.resolve() or where.included_at:
            raise yaml_edit.EditRefused(f"{where}: written in an included file: edit it there")
        lines = [item.content_line + 1 for item in yaml_edit.keyframe_items(text)]
        shared = sum(k.where == where for k in plan.motion.keyframes)
        if where.line not in lines or shared > 1:
            raise yaml_edit.EditRefused(f"{where}: a block of keyframes: edit it in the text")
        return lines.index(where.line), str(where)

    def _edit(self, change: Callable[[str, Plan], str], done: str) -> None:
        if self._write(change, done):
            self.reload()  # outside the lock: the page stays live while the physics runs

    def _write(self, change: Callable[[str, Plan], str], done: str) -> bool:
        """Write the file as ``change`` makes it; True when the file is to be reloaded (written,
        or changed on disk since the page showed it: then it is not overwritten)."""
        with self._lock:
            path, plan = self.session.motion_path, self._plan()
            if plan is None:
                self.refuse("nothing written: the file has never loaded")
                return False
            if self.session.changed_on_disk():
                self.refuse(
                    f"nothing written: {path} changed on disk since the page showed it; "
                    "reloaded it: look, then make the change again"
                )
                return True
            try:
                text = path.read_text(encoding="utf-8")
                new = change(text, plan)
                check_loads(path, new)
            except (yaml_edit.EditRefused, SourceError) as error:
                self.refuse(f"nothing written: {error}")
                return False
            try:
                write_text_atomically(path, new)
            except (ChoreoError, OSError) as error:  # a folder made read-only, a full disk
                self.refuse(f"nothing written: {error}")
                return False
            self._watcher.seen()
            self.note(f"{done} in {path}")
            return True

    # --- the live robot ------------------------------------------------------------------------

    def drive(self, on: bool) -> None:
        with self._lock:
            if self.live is None:
                self.refuse(NO_ROBOT)
                return
            plan = self._plan()
            if on and (plan is None or plan.motion.robot != self.live.robot):
                self.refuse("refused: the motion's robot is not the one the studio connected to")
                self.page.show_driving(False)
                return
            self.driving = on
            self.page.show_driving(on)
            if on and plan is not None:
                self.note("driving the robot: it follows the page at the approach's speed")
                self._redraw(plan)
            else:
                self.live.stop()

    def stop_robot(self) -> None:
        if self.live is not None:
            self.live.stop()  # first, before any lock: nothing may delay a stop
        with self._lock:
            self.driving = False
            self.page.show_driving(False)
            self.note("Stop: the servos were told to stop; the page no longer drives them")

    def unload_joints(self, text: str) -> None:
        """Stop driving and let the joints named in ``text`` (comma or space separated; blank:
        all) go limp, to be posed by hand."""
        if self.live is None:
            self.refuse(NO_ROBOT)
            return
        names = text.replace(",", " ").split() or None
        self.stop_robot()
        try:
            joints = self.live.unload(names)
        except ValueError as error:
            self.refuse(f"refused: {error}")
            return
        self.note(
            f"limp: {', '.join(j.name for j in joints)}: pose them by hand, then Read pose; "
            "Load them again when done"
        )

    def read_pose(self) -> None:
        """The robot's angles now become the sliders' pose (to capture with Add keyframe)."""
        with self._lock:
            plan = self._plan()
            if self.live is None or plan is None:
                self.refuse(NO_ROBOT)
                return
            angles = self.live.read_pose()
            problems = limit_problems(self.live.robot, [float(a) for a in angles])
            if problems:
                self.refuse("not taken: " + "; ".join(problems))
                return
            self._set_pose(np.array(angles), plan)
            self.note("read the robot's pose into the sliders: Add or Update keyframe keeps it")

    def hold_joints(self) -> None:
        if self.live is None:
            self.refuse(NO_ROBOT)
            return
        self.live.hold()
        self.note("the joints hold again")

    def _tab_closed(self, _client) -> None:
        if not self.server.get_clients() and self.driving:
            self.stop_robot()

    # --- notes ---------------------------------------------------------------------------------

    def note(self, text: str, kind: str = "") -> None:
        self._say(text)
        self._last_note = (text, kind)
        self._show_status()

    def refuse(self, text: str) -> None:
        self._say(f"⛔ {text}")  # a terminal has the glyph; the page's fonts may not
        self._last_note = (text, "refused")
        self._show_status()

    def _show_status(self, status: tuple[str, str] | None = None) -> None:
        """One line for the page: the files' state (loading, planned, simulated, or failed and
        why), then what the last action did."""
        if status is not None:
            self._status = status
        text, kind = self._status
        note, note_kind = self._last_note
        if note:
            text, kind = f"{text} · {note}", kind or note_kind
        self.page.show_status(text, kind)
        self.timeline.show_status(text, kind)


def reload_status(result: Reload, plan: Plan | None) -> tuple[str, str]:
    """The status line's first part after a reload, and its kind ("failed" or "")."""
    if result.problems:
        kept = " (the last good plan stays on screen)" if plan is not None else ""
        more = len(result.problems) - 1
        first = result.problems[0] + (f" (and {more} more, listed below)" if more else "")
        return f"reload {result.version} failed: {first}{kept}", "failed"
    assert plan is not None
    physics = plan.physics
    if physics is None:
        return f"reload {result.version} planned: {plan.end_s:.2f} s; simulating…", ""
    findings = physics.findings
    errors = sum(f.severity.value == "error" for f in findings)
    found = (
        f"{len(findings)} finding{'s' * (len(findings) != 1)}"
        + (f" ({errors} error{'s' * (errors != 1)})" if errors else "")
        if findings
        else "no findings: the simulated robot follows the plan"
    )
    return (
        f"reload {result.version} simulated in {physics.took_s:.2f} s: {plan.end_s:.2f} s, {found}",
        "",
    )


def check_loads(path: Path, text: str) -> Motion:
    """The motion ``text`` written to ``path`` would be; ``SourceError`` (naming ``path``) if
    it would not load."""
    trial = path.with_name(f".{path.name}.studio-check{path.suffix}")
    try:
        trial.write_text(text, encoding="utf-8")
        return load_motion(trial)
    except SourceError as error:
        raise SourceError([p.replace(str(trial), str(path)) for p in error.problems]) from None
    except ChoreoError as error:
        raise SourceError(str(error).replace(str(trial), str(path))) from None
    finally:
        trial.unlink(missing_ok=True)
