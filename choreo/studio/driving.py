"""The studio's live robot: the page drives it (``Studio._redraw`` hands it each pose while
driving), stops it, lets joints go limp to be posed by hand and reads the pose they were given.
The bus side, through ``choreo play``'s safety path, is ``live.LiveRobot``."""

from __future__ import annotations

import numpy as np

from choreo.play.recorder import limit_problems
from choreo.studio.parts import StudioParts

# what the page hears when it asks for the robot of a studio given none (its controls are hidden)
NO_ROBOT = "refused: no robot: this studio was started without one to drive"


class Driving(StudioParts):
    """``driving``: the live robot follows the page."""

    def _init_driving(self) -> None:
        self.driving = False

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
