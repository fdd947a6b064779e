"""The page's controls (viser GUI, shared by every tab): what the motion is, its problems, the
timeline, a slider per joint, and the buttons that write keyframes into the file.

The page only shows and asks; ``server.Studio`` decides. A control moved from a page calls one of
the studio's methods; a control the studio sets itself (``event.client is None``) calls nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from choreo.motion.music_block import Music
from choreo.robot.types import Robot
from choreo.studio.session import Plan
from choreo.studio.song import song_html
from choreo.studio.watch import stamp

if TYPE_CHECKING:
    from choreo.studio.server import Studio

SPEEDS = ("0.25", "0.5", "1", "2")
TIME_STEP_S = 0.01
ANGLE_STEP_DEG = 0.1
CURVE_POINTS = 600  # per curve: a few per pixel of the panel
CURVE_COLOURS = ("#2878ff", "#e0561b", "#2ca02c", "#9467bd", "#d62728", "#17becf", "#8c564b")
MAX_MARKS = 60  # beyond this the slider's marks are a smear: the list below names them all


def from_page(action: Callable[[Any], None]) -> Callable[[Any], None]:
    """A callback that runs only for changes made in a page, not for values the studio set."""

    def callback(event: Any) -> None:
        if event.client is not None:
            action(event)

    return callback


class Page:
    def __init__(self, server: Any, studio: Studio, live: bool = False):
        self._server, self._studio = server, studio
        gui = server.gui
        self.title = gui.add_markdown("**choreo studio**: loading…")
        self.problems = gui.add_markdown("", visible=False)
        self.note = gui.add_markdown("", visible=False)
        self.driving: Any = None
        if live:
            with gui.add_folder("Robot"):
                self.driving = gui.add_checkbox("drive the robot", initial_value=False)
                self.stop = gui.add_button("Stop", color="red")
                self.by_hand = gui.add_text("joints to pose by hand", initial_value="")
                self.unload = gui.add_button("Unload them (blank: all)")
                self.read_pose = gui.add_button("Read pose")
                self.hold = gui.add_button("Load them again")
        self.timeline = gui.add_folder("Timeline")
        with self.timeline:
            self.time = self._time_slider(0.0, 1.0, ())
            self.play = gui.add_button("Play")
            self.speed = gui.add_dropdown("speed", SPEEDS, initial_value="1")
            self.ghost = gui.add_checkbox("plan as a ghost", initial_value=True)
            self.snap = gui.add_checkbox("snap to beats", initial_value=False, visible=False)
            self.song = gui.add_html("", visible=False)
            self.where = gui.add_markdown("")
            self.keyframe = gui.add_dropdown("keyframe", ("-",), initial_value="-")
            self.keyframe_info = gui.add_markdown("")
            self.findings = gui.add_markdown("")
        with gui.add_folder("Edit"):
            self.add = gui.add_button("Add keyframe")
            self.update = gui.add_button("Update keyframe")
            self.retime = gui.add_button("Move keyframe here")
            self.delete = gui.add_button("Delete keyframe")
            self.undo = gui.add_button("Undo")
            self.redo = gui.add_button("Redo")
        self.curve_folder = gui.add_folder("Curves", expand_by_default=False)
        self.curve_picks: dict[str, Any] = {}  # joint name -> its "curve" checkbox
        self.curves: Any = None
        self._curve_series: tuple = ()
        self.pose_folder = gui.add_folder("Pose")
        self.joints: dict[str, Any] = {}
        self.pose_names: Any = None
        self._robot: Robot | None = None
        self._keyframe_labels: tuple[str, ...] = ()
        self._song_key: tuple | None = None
        self._timeline_key: tuple = ()
        self._connect()

    def _connect(self) -> None:
        studio = self._studio
        self.play.on_click(lambda _: studio.toggle_play())
        self.speed.on_update(from_page(lambda e: studio.set_speed(e.target.value)))
        self.ghost.on_update(from_page(lambda e: studio.show_ghost(bool(e.target.value))))
        self.keyframe.on_update(from_page(lambda e: studio.select_keyframe(self.keyframe_index())))
        if self.driving is not None:
            self.driving.on_update(from_page(lambda e: studio.drive(bool(e.target.value))))
            self.stop.on_click(lambda _: studio.stop_robot())
            self.unload.on_click(lambda _: studio.unload_joints(self.by_hand.value))
            self.read_pose.on_click(lambda _: studio.read_pose())
            self.hold.on_click(lambda _: studio.hold_joints())
        self.add.on_click(lambda _: studio.add_keyframe())
        self.update.on_click(lambda _: studio.update_keyframe())
        self.retime.on_click(lambda _: studio.retime_keyframe())
        self.delete.on_click(lambda _: studio.delete_keyframe())
        self.undo.on_click(lambda _: studio.undo())
        self.redo.on_click(lambda _: studio.redo())

    # --- what the studio shows -------------------------------------------------------------

    def show_plan(self, plan: Plan, version: int) -> None:
        """The plan, and once simulated what the physics did (the page is told twice)."""
        motion, robot = plan.motion, plan.motion.robot
        self.title.content = (
            f"**motion** `{motion.name}` · **robot** `{robot.name}` · "
            f"{len(motion.keyframes)} keyframes · {plan.end_s:.2f} s  \n"
            f"`{motion.path}`  \n**joints** " + ", ".join(f"`{n}`" for n in robot.joint_names)
        )
        self._show_timeline(plan)
        labels = tuple(
            f"{i + 1} · t {t:.2f} s · {Path(k.where.path).name}:{k.where.line}"
            for i, (k, t) in enumerate(zip(motion.keyframes, plan.keyframe_times_s))
        )
        self._keyframe_labels = labels
        self.snap.visible = motion.music is not None
        self._show_song(motion.music)
        self.keyframe.options = ("-", *labels)
        self.findings.content = self._findings_text(plan, version)
        if robot != self._robot:
            self._build_joints(robot)
            self._build_curve_picks(robot)
        self.show_curves(plan)

    @staticmethod
    def _findings_text(plan: Plan, version: int) -> str:
        physics = plan.physics
        if physics is None:
            return f"**physics**: reload {version} simulating… (the robot shows the plan)"
        status = f"**physics**: reload {version} simulated in {physics.took_s:.2f} s\n\n"
        return status + (
            "\n".join(
                f"- ⚠ {f.time_s:.2f} s {f.severity.value}: {f.message}" for f in physics.findings
            )
            or "no findings: the simulated robot follows the plan"
        )

    def show_curves(self, plan: Plan) -> None:
        """The chosen joints' plan (what the ticks ask, solid) and simulated angle (dashed, once
        the physics is done) over time, one colour per joint."""
        names = plan.motion.robot.joint_names
        chosen = [j for j, name in enumerate(names) if self._picked(name)]
        if not chosen:
            self._remove_curves()
            return
        every = max(1, len(plan.times_s) // CURVE_POINTS)
        times = plan.times_s[::every]
        simulated = (
            plan.physics.simulated_deg(times)
            if plan.physics is not None
            else np.full((len(times), len(names)), np.nan)
        )
        data = [times]
        series: list[dict] = [{"label": "t (s)"}]
        for j in chosen:
            colour = CURVE_COLOURS[j % len(CURVE_COLOURS)]
            data += [plan.command_deg[::every, j], simulated[:, j]]
            series += [
                {"label": f"{names[j]} plan (°)", "stroke": colour, "width": 2},
                {"label": f"{names[j]} sim (°)", "stroke": colour, "width": 1, "dash": (5, 4)},
            ]
        if self.curves is not None and tuple(series) == self._curve_series:
            self.curves.data = tuple(data)  # the same joints: new numbers, the same chart
            return
        self._remove_curves()
        self._curve_series = tuple(series)
        with self.curve_folder:
            self.curves = self._server.gui.add_uplot(
                data=tuple(data),
                series=tuple(series),
                aspect=1.6,
            )

    def _picked(self, name: str) -> bool:
        pick = self.curve_picks.get(name)
        return pick is not None and bool(pick.value)

    def _remove_curves(self) -> None:
        if self.curves is not None:
            self.curves.remove()
        self.curves, self._curve_series = None, ()

    def _build_curve_picks(self, robot: Robot) -> None:
        """A checkbox per joint choosing its curves (the first joint's to begin with)."""
        for pick in self.curve_picks.values():
            pick.remove()
        self._remove_curves()
        with self.curve_folder:
            self.curve_picks = {
                name: self._server.gui.add_checkbox(f"{name} curve", initial_value=i == 0)
                for i, name in enumerate(robot.joint_names)
            }
        for pick in self.curve_picks.values():
            pick.on_update(from_page(lambda _: self._studio.redraw_curves()))

    def _show_timeline(self, plan: Plan) -> None:
        """viser sets a slider's marks once: a plan whose ends or marks changed gets a new
        slider in the same place (only then: a new slider costs the page a re-layout)."""
        key = (round(plan.start_s, 2), round(plan.end_s, 2), self._marks(plan))
        if key == self._timeline_key:
            return
        self._timeline_key = key
        order, value = self.time.order, self.time.value
        self.time.remove()
        with self.timeline:
            self.time = self._time_slider(plan.start_s, plan.end_s, key[2], order)
        self.time.value = float(np.clip(value, self.time.min, self.time.max))

    def _time_slider(
        self, start_s: float, end_s: float, marks: tuple, order: float | None = None
    ) -> Any:
        slider = self._server.gui.add_slider(
            "t (s)",
            min=round(start_s, 2),
            max=round(end_s, 2),
            step=TIME_STEP_S,
            initial_value=round(max(start_s, 0.0), 2),
            marks=marks,
            order=order,
        )
        slider.on_update(from_page(lambda e: self._studio.scrub(float(e.target.value))))
        return slider

    def _show_song(self, music: Music | None) -> None:
        """The song's player, made again only when the song or its start changed."""
        key = None if music is None else (music.song, music.start_s, stamp(music.song))
        if key != self._song_key:
            self._song_key = key
            self.song.content = "" if music is None else song_html(music)
            self.song.visible = music is not None

    def _marks(self, plan: Plan) -> tuple:
        marks: list[tuple[float, str]] = [(round(t, 2), "◆") for t in plan.keyframe_times_s]
        music = plan.motion.music
        if music is not None:  # the bar lines: every bar's first beat
            grid = music.grid
            bars = grid.beat_times_s[:: grid.beats_per_bar]
            marks += [(round(t, 2), f"{i + 1}") for i, t in enumerate(bars) if t <= plan.end_s]
        marks += [(round(f.time_s, 2), "⚠") for f in plan.findings]
        if plan.start_s < 0:
            marks.append((round(plan.start_s, 2), "approach"))
        return tuple(marks[:MAX_MARKS])

    def _build_joints(self, robot: Robot) -> None:
        self._robot = robot
        self.pose_folder.remove()
        gui, studio = self._server.gui, self._studio
        self.pose_folder = gui.add_folder("Pose")
        with self.pose_folder:
            self.joints = {}
            for joint in robot.joints:
                slider = gui.add_slider(
                    joint.name,
                    min=joint.limits.min_deg,
                    max=joint.limits.max_deg,
                    step=ANGLE_STEP_DEG,
                    initial_value=float(np.clip(0.0, joint.limits.min_deg, joint.limits.max_deg)),
                )
                slider.on_update(from_page(self._joint_moved(joint.name)))
                self.joints[joint.name] = slider
            names = tuple(robot.poses) or ("-",)
            self.pose_names = gui.add_dropdown("named pose", names, initial_value=names[0])
            gui.add_button("Take the named pose").on_click(
                lambda _: studio.take_pose(self.pose_names.value)
            )
            mirror = gui.add_button("Mirror left/right", disabled=not robot.mirror_pairs)
            mirror.on_click(lambda _: studio.mirror())
            gui.add_button("Back to the plan").on_click(lambda _: studio.follow_plan())

    def _joint_moved(self, name: str) -> Callable[[Any], None]:
        return lambda event: self._studio.move_joint(name, event.target.value)

    def show_problems(self, problems: tuple[str, ...]) -> None:
        self.problems.visible = bool(problems)
        if problems:
            self.problems.content = (
                "**The file does not load** (the last good plan stays on screen):\n\n"
                "```\n" + "\n".join(problems) + "\n```"
            )

    def show_driving(self, on: bool) -> None:
        if self.driving is not None:
            self.driving.value = on

    def show_note(self, text: str) -> None:
        self.note.visible = bool(text)
        self.note.content = text

    def show_time(self, t_s: float, text: str) -> None:
        self.time.value = round(t_s, 2)
        self.where.content = text

    def show_joints(self, angles_deg: np.ndarray) -> None:
        for slider, angle in zip(self.joints.values(), angles_deg):
            slider.value = round(float(angle), 1)

    def show_keyframe(self, index: int | None, text: str) -> None:
        self.keyframe.value = "-" if index is None else self._keyframe_labels[index]
        self.keyframe_info.content = text

    # --- what the page asks ------------------------------------------------------------------

    def keyframe_index(self) -> int | None:
        value = self.keyframe.value
        return self._keyframe_labels.index(value) if value in self._keyframe_labels else None

    def pose_deg(self) -> np.ndarray:
        return np.array([float(s.value) for s in self.joints.values()])
