"""The page driving a robot (or the emulator) through the same safety path as ``choreo play``.

``preflight`` first (every servo answers, is fit, and gets torque); then each pose the page asks
for is reached by the player's approach: planned from where the servos are, at the approach's
share of every joint's limits, sent as staged moves with a broadcast START where the transport
has one. Only the newest pose is kept: a scrubbing page is followed, never queued. ``stop``
stops the servos at once (the player's MOVE_STOP) and drives nothing more until asked again.

One thread owns the bus: the page's threads only leave requests for it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

import numpy as np

from choreo.bus.servo_bus import ServoBus
from choreo.bus.servo_config import set_torque
from choreo.core.clock import Clock
from choreo.errors import ChoreoError
from choreo.plan.planner import APPROACH_LIMIT_SCALE, plan_approach
from choreo.plan.ticks import compile_ticks
from choreo.play.player import Outcome, Player, PlayOptions, preflight
from choreo.play.recorder import taught_joints
from choreo.robot.types import Joint, Robot

MIN_MOVE_DEG = 0.2  # below a servo's step (0.24°): not worth a move


class _Stopped(KeyboardInterrupt):
    """Raised inside the player's progress callback: the player stops the servos on it."""


class LiveRobot:
    """The robot on ``bus`` following the page's pose once ``drive`` is on."""

    def __init__(self, bus: ServoBus, robot: Robot, clock: Clock, say: Callable[[str], None]):
        self.bus, self.robot, self.clock, self._say = bus, robot, clock, say
        start, self._limits = preflight(bus, robot)  # ChoreoError: nothing has moved
        self.pose_deg = np.array(start)  # where the servos are (measured, then as moved)
        self._wanted: np.ndarray | None = None
        self._stop_requested = False
        self._closing = False
        self._wake = threading.Condition()
        self._bus_lock = threading.RLock()  # a move, a stop, a read: one at a time on the wire
        self.limp: tuple[Joint, ...] = ()  # unloaded to be posed by hand
        self._thread = threading.Thread(target=self._run, name="studio-live", daemon=True)
        self._thread.start()

    def follow(self, angles_deg: Sequence[float] | np.ndarray) -> None:
        """Move to ``angles_deg`` (joint order) as soon as the current move ends."""
        if self.limp:
            return  # never drive a robot being posed by hand
        with self._wake:
            self._wanted = np.array(angles_deg, dtype=float)
            self._stop_requested = False
            self._wake.notify()

    def stop(self) -> None:
        """Stop the servos now: the move under way is cut short, none waiting is made."""
        with self._wake:
            self._wanted = None
            self._stop_requested = True
            self._wake.notify()

    def close(self) -> None:
        with self._wake:
            self._closing = True
            self._stop_requested = True
            self._wake.notify()
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._wake:
                while self._wanted is None and not self._closing and not self._stop_requested:
                    self._wake.wait()
                if self._stop_requested:
                    self._stop_requested = self._closing
                    self._halt()
                if self._closing:
                    return
                wanted, self._wanted = self._wanted, None
            if wanted is not None and np.max(np.abs(wanted - self.pose_deg)) >= MIN_MOVE_DEG:
                self._move(wanted)

    # --- posing by hand (``choreo record``'s way: unload, pose, read, load again) ---------------

    def unload(self, names: Sequence[str] | None) -> tuple[Joint, ...]:
        """Stop, then let the joints named (all: None) go limp; ``ValueError`` for a name the
        robot has not."""
        joints = taught_joints(self.robot, names)
        self.stop()
        with self._bus_lock:
            for joint in joints:
                self.bus.unload(joint.servo_id)
            self.bus.drain()  # limp before the user is told to pose
            self.limp = joints
        return joints

    def read_pose(self) -> np.ndarray:
        """Every joint's angle now (degrees, joint order)."""
        with self._bus_lock:
            self._measure()
            return self.pose_deg.copy()

    def hold(self) -> None:
        """Load the limp joints again: they hold where the hand left them."""
        with self._bus_lock:
            for joint in self.limp:
                set_torque(self.bus, joint.servo_id, True)
            self.limp = ()
            self._measure()

    def _halt(self) -> None:
        with self._bus_lock:
            Player(self.bus, self.robot, self.clock, self._limits).stop()
            self._measure()
        self._say("stopped the servos")

    def _move(self, wanted: np.ndarray) -> None:
        trajectory = plan_approach(self.robot, self.pose_deg, wanted, APPROACH_LIMIT_SCALE)
        ticks = compile_ticks(
            trajectory, self.robot, tolerance_deg=PlayOptions().tolerance_deg
        ).ticks
        player = Player(self.bus, self.robot, self.clock, self._limits, on_progress=self._check)
        try:
            with self._bus_lock:
                report = player.play(ticks, tuple(self.pose_deg))
        except ChoreoError as error:  # the bus went away
            self._say(f"the robot stopped: {error}")
            self.stop()
            return
        if report.outcome is Outcome.COMPLETED:
            self.pose_deg = wanted
            return
        self._measure()
        if report.outcome is Outcome.ABORTED:
            self._say(f"the robot stopped for safety: {report.reason}")
            with self._wake:  # a servo that faulted must not be driven again unasked
                self._wanted = None

    def _check(self, _progress) -> None:
        if self._stop_requested:
            raise _Stopped

    def _measure(self) -> None:
        try:
            units = [self.bus.read_position(j.servo_id) for j in self.robot.joints]
        except ChoreoError as error:
            self._say(f"could not read where the servos stopped: {error}")
            return
        self.pose_deg = self.robot.to_deg(units)
