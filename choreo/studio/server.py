"""The studio: one motion file, one address, every tab showing the same state.

``Studio`` is made of one part per concern (``parts``): the timeline, posing, editing with its
journal, and the live robot; here are its life (start, reload, close) and what ties the parts.

Threads: viser calls the page's callbacks from its own threads, the file watcher and the player
run in theirs; ``Studio._lock`` makes each change of state whole (a reload never interleaves with
an edit or a redraw).

Serving: the ``Front`` listens at the address asked for; behind it, on loopback ports the system
picks, viser serves the 3D view and its panel, and the timeline's page its own (under
``timeline_server.ROOT``).
"""

from __future__ import annotations

import contextlib
import io
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from choreo.studio import require
from choreo.studio.address import Address
from choreo.studio.driving import NO_ROBOT, Driving
from choreo.studio.editing import Editing
from choreo.studio.front import LOOPBACK
from choreo.studio.live import LiveRobot
from choreo.studio.page import Page
from choreo.studio.posing import LatestOnly, Posing
from choreo.studio.scene import RobotView
from choreo.studio.serving import UnreadableMessages, front_at
from choreo.studio.session import Reload, Session
from choreo.studio.timeline import Timeline
from choreo.studio.timeline_page import TimelinePage, reload_status
from choreo.studio.timeline_server import ROOT
from choreo.studio.trial import check_loads
from choreo.studio.watch import FileWatcher

__all__ = ["NO_ROBOT", "LatestOnly", "Studio", "check_loads"]


class Studio(Timeline, Posing, Editing, Driving):
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
        self._init_timeline()
        self._init_posing()
        self._init_editing()
        self._init_driving()
        self.front = front_at(listen)  # the one address a user sees: a wrong one is one line
        self.address = Address(listen.host, self.front.port)
        self._unreadable = UnreadableMessages(say)
        self._unreadable.install()
        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: the CLI says the URL
            self.server = viser.ViserServer(host=LOOPBACK, port=0, verbose=False)
        # The page's "share" asks viser's relay for a public URL: never, this page writes files.
        self.server.request_share_url = lambda *args, **kwargs: None
        self.live = live
        self.timeline_page = TimelinePage(self)
        self.page = Page(self.server, self, live=live is not None)
        self.server.on_client_disconnect(self._tab_closed)
        self.server.scene.on_click()(self._clicked)
        self.view = None
        self._stop = threading.Event()
        self._watcher = FileWatcher(lambda: self.session.watched_files, self.reload)
        self._player = threading.Thread(target=self._play_loop, name="studio-play", daemon=True)

    def start(self) -> None:
        self.timeline_page.start()
        self.front.start(self.server.get_port(), {ROOT: self.timeline_page.port})
        self.reload()
        self._watcher.start()
        self._player.start()

    def close(self) -> None:
        if self.live is not None:
            self.live.close()
        self._stop.set()
        self._watcher.stop()
        self.front.close()  # first: no tab sends anything more
        self.timeline_page.close()
        if self._player.is_alive():
            self._player.join(timeout=2.0)
        with self._lock, contextlib.redirect_stdout(io.StringIO()):  # viser's "Server stopped"
            self.server.stop()  # (a reload under way shows nothing more: ``_show_reload``)
        self._unreadable.remove()

    def wait(self) -> None:
        """Until ``close`` (another thread) or Ctrl-C."""
        while not self._stop.wait(0.2):
            pass

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
        if self._stop.is_set():
            return  # closed while simulating: no page to show it on
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
            if self.view is not None and self.view.robot.joint_names != motion.robot.joint_names:
                self._back_to_the_plan()  # the sliders posed the robot shown before: not this one
            self.server.scene.reset()
            self.view = RobotView(self.server, motion.robot, motion.props)
            self._add_site_handles(plan)
        self.page.show_plan(plan)
        self.timeline_page.show_plan(plan, result.version, self.view.limbs())
        if not result.problems:
            self._follow_selection(plan)
        self.time_s = float(np.clip(self.time_s, plan.start_s, plan.end_s))
        self._redraw(plan)
        if self.posing is None:
            self.page.show_joints(plan.planned_deg(self.time_s))

    def frame_robot(self) -> None:
        """Every tab's camera on the robot as it stands now."""
        with self._lock:
            if self.view is not None:
                self.view.frame_camera(tuple(self.server.get_clients().values()))

    def _clicked(self, event) -> None:
        """A click in the 3D view (not a drag): a link's joint picked to turn."""
        self.pick_joint(np.array(event.ray_origin), np.array(event.ray_direction))

    def _tab_closed(self, _client) -> None:
        """With the last tab gone, nothing plays and nothing is driven: a tab opened later finds
        the timeline where it stopped."""
        if self.server.get_clients():
            return
        if self.driving:
            self.stop_robot()
        with self._lock:
            if self.playing:
                self.toggle_play()
