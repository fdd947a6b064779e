"""What the studio's parts share: the state each part reads, and the notes every part writes.

``server.Studio`` is made of one part per concern, each its own module: ``timeline.Timeline``
(time, play, redraw), ``posing.Posing`` (sliders and handles), ``editing.Editing`` (writes and
their journal) and ``driving.Driving`` (the live robot). Each part owns the state it sets; this
base names what the others read of it, so that each part type-checks on its own.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from choreo.studio.session import Plan, Session

if TYPE_CHECKING:
    from choreo.motion.gait import BodyPose
    from choreo.robot.kinematics import SiteGoal
    from choreo.studio.live import LiveRobot
    from choreo.studio.page import Page
    from choreo.studio.scene import RobotView
    from choreo.studio.timeline_page import TimelinePage
    from choreo.studio.watch import FileWatcher


class StudioParts:
    """The state of a studio that more than one of its parts reads (set in ``Studio.__init__``
    and by the part that owns each)."""

    session: Session
    server: Any  # viser.ViserServer
    page: Page
    view: RobotView | None
    live: LiveRobot | None
    _lock: threading.RLock  # each change of state whole: viser's, the watcher's, the player's
    _say: Callable[[str], None]
    _watcher: FileWatcher
    _stop: threading.Event  # set by ``close``: every thread of the studio ends
    timeline_page: TimelinePage  # the timeline at the bottom of the page
    _status: tuple[str, str] = ("loading…", "")  # the files' state for the status line, its kind
    _last_note: tuple[str, str] = ("", "")  # what the last action did, and its kind
    # the timeline's
    time_s: float
    playing: bool
    # posing's: the sliders' pose once a slider or a handle moved, and what made it
    posing: np.ndarray | None
    site_goal: SiteGoal | None
    body_goal: BodyPose | None
    _posed_root: tuple[np.ndarray, np.ndarray] | None
    # driving's
    driving: bool

    def _plan(self) -> Plan | None:
        return self.session.plan

    def note(self, text: str) -> None:
        self._say(text)
        self._last_note = (text, "")
        self._show_status()

    def refuse(self, text: str) -> None:
        self._say(f"⛔ {text}")  # a terminal has the glyph; the page's fonts may not
        self._last_note = (text, "refused")
        self._show_status()

    def _show_status(self, status: tuple[str, str] | None = None) -> None:
        """One line for the page and its timeline: the files' state (loading, planned,
        simulated, or failed and why), then what the last action did."""
        if status is not None:
            self._status = status
        text, kind = self._status
        note, note_kind = self._last_note
        if note:
            text, kind = f"{text} · {note}", kind or note_kind
        self.page.show_status(text, kind)
        self.timeline_page.show_status(text, kind)

    if TYPE_CHECKING:  # what one part asks of another (defined in the part named)

        def reload(self) -> None: ...  # server.Studio

        def scrub(self, t_s: float) -> None: ...  # timeline

        def _redraw(self, plan: Plan) -> None: ...  # timeline

        def _pose(self) -> np.ndarray: ...  # posing

        def _set_pose(self, pose: np.ndarray | None, plan: Plan | None = None) -> None: ...

        def _back_to_the_plan(self) -> None: ...  # posing

        def stop_robot(self) -> None: ...  # driving
