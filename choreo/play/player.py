"""The player: plays a list of ticks on the servos of a robot, then stops or leaves them.

``Player.play`` streams the ticks on an absolute clock (``choreo.play.stream``), sent the way the
transport can (``choreo.play.tick_sending``), with health reads in the spare bus time
(``choreo.play.health``), at real-time priority where permitted (``choreo.play.realtime``). It
expects ``preflight`` (``choreo.play.preflight``) to have passed. Every exit path other than
completion stops the servos (``capabilities.stop``: a broadcast MOVE_STOP on the raw bus); then
``leave`` leaves them as configured: holding (torque on), moved slowly to an exit pose, or
unloaded.
"""

from __future__ import annotations

import contextlib
import gc
import logging
from collections.abc import Callable, Sequence

from choreo.bus.servo_bus import ServoBus
from choreo.core.arguments import check_callable, check_member, check_number, check_type, shown
from choreo.core.clock import Clock, RealClock
from choreo.errors import BusError, OptionError, PlaybackAborted, ServoFault
from choreo.plan.approach import slow_approach
from choreo.plan.performance import servo_pose
from choreo.plan.ticks import Tick
from choreo.play.health import HealthReads, ServoHealth
from choreo.play.play_options import ExitMode, PlayOptions
from choreo.play.preflight import ServoLimits, check_bus_and_robot
from choreo.play.realtime import NOT_ASKED, Scheduling, realtime_priority
from choreo.play.report import Outcome, PlayProgress, StreamReport
from choreo.play.stream import Stream
from choreo.play.tick_sending import tick_sending
from choreo.robot.types import Robot

log = logging.getLogger(__name__)
DEFAULT_OPTIONS = PlayOptions()


class Player:
    """Streams ticks to the servos of ``robot`` on ``bus`` with deadlines from ``clock``."""

    def __init__(
        self,
        bus: ServoBus,
        robot: Robot,
        clock: Clock,
        limits: dict[str, ServoLimits],
        options: PlayOptions = DEFAULT_OPTIONS,
        on_progress: Callable[[PlayProgress], None] | None = None,
    ):
        _check_player(bus, robot, clock, limits, options, on_progress)
        self.bus, self.robot, self.clock, self.options = bus, robot, clock, options
        self.limits = limits
        self.on_progress = on_progress
        # Called once per play with the clock time of the first START, before anything is sent
        # (the song is cued on it: choreo/play/soundtrack.py).
        self.on_first_start: Callable[[float], None] | None = None
        # Called once per play with the priority it got, before anything is sent.
        self.on_scheduling: Callable[[Scheduling], None] | None = None
        self.health_reads = HealthReads(bus, robot, limits, options)

    @property
    def health(self) -> tuple[ServoHealth, ...]:
        """What the health reads saw on each servo, over every play of this player."""
        return self.health_reads.records

    def play(
        self,
        ticks: Sequence[Tick],
        start_pose_deg: Sequence[float],
        start_at_s: float | None = None,
    ) -> StreamReport:
        """Play ``ticks`` from ``start_pose_deg`` (where the servos are now): the first START as
        soon as tick 0 is staged, or at ``start_at_s`` on the clock (a show's instant: if that
        is already past, the servos are re-targeted to where the plan is by then)."""
        ticks = _checked_ticks(ticks)
        start_pose_deg = servo_pose(self.robot, start_pose_deg)
        if start_at_s is not None:
            check_number("start_at_s", start_at_s)
        # The priority first: locking the memory takes a while, before the deadlines are set.
        with self._priority() as scheduling:
            if self.on_scheduling:
                self.on_scheduling(scheduling)
            stream = Stream(
                ticks,
                self.robot.to_units(start_pose_deg),
                clock=self.clock,
                sending=tick_sending(self.bus, self.robot),
                health=self.health_reads,
                lead_s=self.options.lead_s,
                start_guard_s=self.options.start_guard_s,
                on_progress=self.on_progress,
                start_at_s=start_at_s,
            )
            self._run(stream)
            return stream.report(scheduling)

    def _run(self, stream: Stream) -> None:
        """Run ``stream``; on any way out but the end, stop the servos at once."""
        collecting = gc.isenabled()
        gc.disable()  # a full collection can pause for tens of ms; streaming makes no cycles
        try:
            stream.run(self.on_first_start)
        except KeyboardInterrupt:
            self.stop()
            stream.finish(Outcome.INTERRUPTED, "interrupted")
        except (PlaybackAborted, ServoFault) as error:
            self.stop()
            stream.finish(Outcome.ABORTED, str(error))
        except BaseException:
            self.stop()
            raise
        finally:
            if collecting:
                gc.enable()

    def _priority(self) -> contextlib.AbstractContextManager[Scheduling]:
        wanted = self.options.realtime
        if wanted is None:
            wanted = isinstance(self.clock, RealClock)
        return realtime_priority() if wanted else contextlib.nullcontext(NOT_ASKED)

    def stop(self) -> None:
        """Stop every servo by the transport's best means (``capabilities.stop``: a broadcast
        MOVE_STOP on the raw bus).

        Moves still waiting in the output buffer are dropped so the stop goes out first.
        """
        try:
            self.bus.discard_output()
            self.bus.stop_servos([j.servo_id for j in self.robot.joints])
            self.bus.drain()
        except (BusError, OSError) as error:  # the port itself may be gone
            log.error("could not send MOVE_STOP: %s", error)

    def leave(self, outcome: Outcome) -> StreamReport | None:
        """Leave the servos as configured: holding (nothing to do), at the exit pose, unloaded.
        Returns the report of the move to the exit pose, if one was made.

        After an abort the robot is not moved again: a lost or hot servo must not be driven.
        """
        outcome = check_member("outcome", outcome, Outcome)
        mode, exit_move = self.options.exit_mode, None
        if mode is ExitMode.POSE and outcome is not Outcome.ABORTED:
            exit_move = go_to_pose(self, self.options.exit_pose)
        elif mode is ExitMode.UNLOAD:
            for joint in self.robot.joints:
                self.bus.unload(joint.servo_id)
        self.bus.drain()  # the port may close next: let the last commands out first
        return exit_move


def _checked_ticks(ticks: object) -> list[Tick]:
    """``ticks`` as a list, if they are ticks (a Performance's: ``prepare(...).ticks``)."""
    listed = list(ticks) if isinstance(ticks, Sequence) and not isinstance(ticks, str) else None
    if listed is None or not all(isinstance(tick, Tick) for tick in listed):
        raise OptionError(
            "ticks",
            f"must be a list of Ticks, as a Performance's (prepare(...).ticks), got {shown(ticks)}",
        )
    return listed


def go_to_pose(player: Player, pose: str) -> StreamReport:
    """Move slowly from wherever the servos are to a named pose of the robot (the exit pose),
    with health records of its own."""
    robot, options = player.robot, player.options
    start = [j.to_deg(player.bus.read_position(j.servo_id)) for j in robot.joints]
    approach = slow_approach(robot, start, robot.pose_vector(pose), options.tolerance_deg)
    mover = Player(player.bus, robot, player.clock, player.limits, options)
    return mover.play(approach.tick_plan.ticks, start)


def _check_player(bus, robot, clock, limits, options, on_progress) -> None:
    """Refuse what a Player cannot play with (``OptionError`` naming the argument)."""
    check_bus_and_robot(bus, robot)
    if not all(callable(getattr(clock, name, None)) for name in ("now", "sleep_until")):
        raise OptionError(
            "clock", f"must be a clock (bus.clock, RealClock(), VirtualClock()), got {shown(clock)}"
        )
    if not isinstance(limits, dict):
        raise OptionError(
            "limits",
            f"must be each joint's ServoLimits by name, as preflight returns them, got "
            f"{shown(limits)}",
        )
    missing = [j.name for j in robot.joints if j.name not in limits]
    if missing:
        raise OptionError(
            "limits", f"has none for {', '.join(missing)}: pass what preflight returns"
        )
    check_type("options", options, PlayOptions, "a PlayOptions: PlayOptions(speed=2)")
    check_callable("on_progress", on_progress, optional=True)
