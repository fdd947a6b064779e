"""The page's controls (viser GUI, shared by every tab): what the motion is, one status line,
the time, a slider per joint, and the buttons that write keyframes into the file; the timeline
(``timeline_page``) is framed in at the bottom.

The page only shows and asks; ``server.Studio`` decides. A control moved from a page calls one of
the studio's methods; a control the studio sets itself (``event.client is None``) calls nothing.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from choreo.robot.types import Robot
from choreo.studio.session import Plan
from choreo.studio.timeline_server import frame_html

if TYPE_CHECKING:
    from choreo.studio.server import Studio

SPEEDS = ("0.25", "0.5", "1", "2")
TIME_STEP_S = 0.01
ANGLE_STEP_DEG = 0.1
TITLE = "choreo studio"
STATUS_COLOURS = {"failed": "#b00020", "refused": "#b00020"}


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
        gui.configure_theme(show_logo=False, show_share_button=False)
        gui.set_panel_label(TITLE)
        gui.add_html(frame_html(TITLE))
        self.title = gui.add_markdown(f"**{TITLE}**")
        self.status = gui.add_html(status_html("loading…", ""))
        self.problems = gui.add_html("", visible=False)
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
            self.where = gui.add_markdown("")
            self.keyframe = gui.add_dropdown("keyframe", ("-",), initial_value="-")
            self.keyframe_info = gui.add_markdown("")
        with gui.add_folder("Edit"):
            self.add = gui.add_button("Add keyframe")
            self.update = gui.add_button("Update keyframe")
            self.retime = gui.add_button("Move keyframe here")
            self.delete = gui.add_button("Delete keyframe")
            self.undo = gui.add_button("Undo")
            self.redo = gui.add_button("Redo")
        self.pose_folder = gui.add_folder("Pose")
        self.joints: dict[str, Any] = {}
        self.pose_names: Any = None
        self._robot: Robot | None = None
        self._keyframe_labels: tuple[str, ...] = ()
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

    def show_plan(self, plan: Plan) -> None:
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
        self.keyframe.options = ("-", *labels)
        if robot != self._robot:
            self._build_joints(robot)

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

    def _marks(self, plan: Plan) -> tuple:
        """The slider's marks: where the motion starts, and the approach before it (the
        keyframes, bars and findings are the timeline's)."""
        marks = [(0.0, "0")]
        if plan.start_s < 0:
            marks.append((round(plan.start_s, 2), "approach"))
        return tuple(marks)

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
            gui.add_button("Frame the robot").on_click(lambda _: studio.frame_robot())

    def _joint_moved(self, name: str) -> Callable[[Any], None]:
        return lambda event: self._studio.move_joint(name, event.target.value)

    def show_problems(self, problems: tuple[str, ...]) -> None:
        """The problems of a file that does not load after the first (the status line says
        that one), each wrapped to the panel's width."""
        problems = problems[1:]
        self.problems.visible = bool(problems)
        if problems:
            self.problems.content = (
                '<ul style="margin: 0; padding-left: 1.2em; overflow-wrap: anywhere">'
                + "".join(f"<li><code>{html.escape(p)}</code></li>" for p in problems)
                + "</ul>"
            )

    def show_status(self, text: str, kind: str) -> None:
        self.status.content = status_html(text, kind)

    def show_driving(self, on: bool) -> None:
        if self.driving is not None:
            self.driving.value = on

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


def status_html(text: str, kind: str) -> str:
    """The status line: wrapped, never clipped; red when the files failed or a request was
    refused."""
    colour = STATUS_COLOURS.get(kind, "inherit")
    return (
        f'<div role="status" style="color: {colour}; white-space: normal; '
        f'overflow-wrap: anywhere; font-size: 0.85em">{html.escape(text)}</div>'
    )
