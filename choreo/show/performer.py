"""``choreo perform``: one robot's computer in a show.

It announces itself (a liveliness token, and ``info``), answers clock round trips at once (in
Zenoh's thread), and takes the rest in its main thread, one at a time: a staged part is unpacked,
compiled and preflighted on its own bus (the answer lists every problem); ``go`` plays it with
its first START at the instant the conductor picked. A stop from the conductor, or the
conductor's liveliness token vanishing, stops the servos at once: the player's clock wakes from
its wait and the player sends MOVE_STOP.
"""

from __future__ import annotations

import queue
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import Clock, RealClock
from choreo.emulator import BusEmulator
from choreo.emulator.trace import START_SLACK_S, WireTrace
from choreo.errors import ChoreoError, PlaybackAborted, SourceError
from choreo.plan.performance import Performance, prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import ServoLimits, preflight, unchecked
from choreo.play.report import Outcome, PlayProgress, StreamReport

# Loading a robot checks its MJCF with MuJoCo, slow to import (a second on a Pi): import it when
# the performer starts, not while it stages a part during the show's countdown.
from choreo.robot import model_check  # noqa: F401
from choreo.robot.types import Robot
from choreo.show.messages import (
    Announcement,
    ClockReading,
    Finished,
    Go,
    PartOutcome,
    PartProgress,
    Readiness,
    StagedPart,
    Stop,
    decode,
    encode,
)
from choreo.show.network import Network, Request, performer_key, show_key
from choreo.show.staging import unpack

PROGRESS_PERIOD_S = 0.25
WAIT_STEP_S = 0.1  # how often the idle loop looks at the stop flag

OpenBus = Callable[[Robot], ServoBus]


class StoppableClock:
    """A real clock whose waits end early, raising ``PlaybackAborted``, once ``stopped`` is set
    (the player then stops the servos, as after a failed health check)."""

    def __init__(self, clock: Clock, stopped: threading.Event, reason: Callable[[], str]):
        self.clock, self.stopped, self.reason = clock, stopped, reason

    def now(self) -> float:
        return self.clock.now()

    def sleep_until(self, deadline_s: float) -> None:
        spin_s = 0.001
        while not self.stopped.wait(max(0.0, deadline_s - self.clock.now() - spin_s)):
            if self.clock.now() >= deadline_s - spin_s:
                self.clock.sleep_until(deadline_s)
                return
        raise PlaybackAborted(self.reason())


@dataclass
class _Staged:
    """A part ready to play: its bus is open, its servos loaded and holding."""

    show_id: str
    robot: Robot
    bus: ServoBus
    emulator: BusEmulator | None
    performance: Performance
    start_pose: tuple[float, ...]
    limits: dict[str, ServoLimits]
    folder: tempfile.TemporaryDirectory
    cancels: list[Callable[[], None]]


class Performer:
    def __init__(
        self,
        network: Network,
        name: str,
        open_bus: OpenBus,
        transport: str,
        say: Callable[[str], None],
    ):
        self.network, self.name, self.open_bus = network, name, open_bus
        self.transport, self.say = transport, say
        self.state, self.robot = "idle", ""
        self.requests: queue.Queue[tuple[str, Request]] = queue.Queue()
        self.stopped = threading.Event()
        self.stop_reason = ""
        key = performer_key(name)
        network.serve(f"{key}/info", lambda r: r.reply(encode(self.announcement())))
        network.serve(f"{key}/clock", lambda r: r.reply(encode(ClockReading(time.time()))))
        network.serve(f"{key}/stage", lambda r: self.requests.put(("stage", r)))
        network.serve(f"{key}/go", lambda r: self.requests.put(("go", r)))
        network.announce(key)

    def announcement(self) -> Announcement:
        return Announcement(self.name, self.transport, self.robot, self.state)

    def stop(self, reason: str) -> None:
        """From any thread: stop the servos of the part staged or playing now."""
        if not self.stopped.is_set():
            self.stop_reason = reason
            self.stopped.set()

    def _on_conductor(self, _key: str, alive: bool) -> None:
        if not alive:
            self.stop("lost the conductor (its liveliness token vanished)")

    def _on_stop(self, _key: str, payload: bytes) -> None:
        self.stop(f"stopped by the conductor: {decode(Stop, payload).reason}")

    # --- the main loop -------------------------------------------------------------------------
    def serve_forever(self) -> None:
        """Take parts and play them until Ctrl-C (KeyboardInterrupt, servos stopped first)."""
        staged: _Staged | None = None
        try:
            while True:
                try:
                    kind, request = self.requests.get(timeout=WAIT_STEP_S)
                except queue.Empty:
                    if staged is not None and self.stopped.is_set():
                        self.say(f"{self.stop_reason}: part dropped, servos stopped")
                        self._release(staged, stop=True)
                        staged = None
                    continue
                if kind == "stage":
                    if staged is not None:
                        self._release(staged, stop=False)
                    staged = self._stage(request)
                elif staged is None:
                    request.reply(encode(Readiness(self.name, "", ("no part is staged",))))
                else:
                    try:
                        self._play(staged, request)
                    finally:
                        self._release(staged, stop=False)
                        staged = None
        finally:
            if staged is not None:
                self._release(staged, stop=True)

    def _stage(self, request: Request) -> _Staged | None:
        self.stopped.clear()
        folder = tempfile.TemporaryDirectory(prefix="choreo-part-")
        try:
            part = decode(StagedPart, request.payload)
            motion = unpack(part, Path(folder.name))
            compiled = compile_motion(motion)
        except SourceError as error:
            folder.cleanup()
            self._refuse(request, "", *error.problems)
            return None
        except ChoreoError as error:
            folder.cleanup()
            self._refuse(request, "", *str(error).splitlines())
            return None
        robot = motion.robot
        try:
            bus = self.open_bus(robot)
        except (ChoreoError, OSError) as error:  # a port that is not there, or busy
            folder.cleanup()
            self._refuse(request, robot.name, f"cannot open its bus: {error}")
            return None
        emulator = bus.emulator
        try:
            _real_clock(bus)
            start_pose, limits = preflight(bus, robot)
        except ChoreoError as error:
            bus.close()
            folder.cleanup()
            self._refuse(
                request, robot.name, *str(error).removeprefix("refusing to play:").splitlines()
            )
            return None
        performance = prepare(compiled, start_pose)
        staged = _Staged(
            part.show_id, robot, bus, emulator, performance, start_pose, limits, folder, []
        )
        conductor = show_key(part.show_id)
        staged.cancels.append(self.network.watch(conductor, self._on_conductor))
        staged.cancels.append(self.network.subscribe(f"{conductor}/stop", self._on_stop))
        self.state, self.robot = "staged", robot.name
        request.reply(
            encode(
                Readiness(
                    self.name,
                    robot.name,
                    (),
                    performance.approach_s,
                    compiled.trajectory.duration_s,
                    tuple(unchecked(bus)),
                )
            )
        )
        self.say(f"staged {part.motion} for {robot.name}: preflight passed")
        return staged

    def _refuse(self, request: Request, robot: str, *problems: str) -> None:
        """Answer a part with the problems that keep it from playing here."""
        lines = tuple(p.strip() for p in problems if p.strip())
        request.reply(encode(Readiness(self.name, robot, lines)))
        self.say(f"refused the part: {'; '.join(lines)}")

    def _play(self, staged: _Staged, request: Request) -> None:
        go = decode(Go, request.payload)
        request.reply(encode(self.announcement()))
        self.state = "playing"
        self.say(f"playing: the part starts in {go.start_s - time.time():.2f} s")
        clock = _real_clock(staged.bus)
        # the wall-clock instant on this process's monotonic clock (read together, close enough)
        began_s = clock.now()
        wall_to_clock_s = began_s - time.time()
        first_start = go.start_s + wall_to_clock_s - staged.performance.approach_s
        report = play_part(
            self, staged, StoppableClock(clock, self.stopped, lambda: self.stop_reason), first_start
        )
        wire = WireTrace.of(staged.emulator) if staged.emulator is not None else None
        finished = self._finished(staged, report, began_s, wall_to_clock_s, wire)
        self.network.publish(f"{show_key(staged.show_id)}/events/{self.name}", encode(finished))
        self.say(
            f"part {finished.outcome.value}{': ' + finished.reason if finished.reason else ''}"
        )
        if wire is not None:
            self.say(wire_summary(wire, began_s))
        if report.outcome is Outcome.INTERRUPTED:
            raise KeyboardInterrupt  # Ctrl-C here: after the conductor was told

    def _finished(
        self,
        staged: _Staged,
        report: StreamReport,
        began_s: float,
        wall_to_clock_s: float,
        wire: WireTrace | None,
    ) -> Finished:
        """How the part ended; on an emulated bus (``wire``), its STARTs and STOP as the wire
        saw them."""
        outcome, reason = PartOutcome(report.outcome.value), report.reason
        if report.outcome is Outcome.ABORTED and self.stopped.is_set():  # the clock's abort
            outcome, reason = PartOutcome.STOPPED, self.stop_reason
        first_start = report.start_time_s + staged.performance.approach_s
        approach_start = report.start_time_s + (
            report.lateness_ms[0] / 1000 if report.lateness_ms else 0
        )
        stop = None
        if wire is not None:
            starts = wire.start_times_s(report.start_time_s)
            approach_start = starts[0] if starts else approach_start
            first_start = next((s for s in starts if s >= first_start - START_SLACK_S), first_start)
            stop = wire.last_stop_s(began_s)
        return Finished(
            self.name,
            outcome,
            reason,
            report.ticks_played,
            report.ticks_total,
            approach_start - wall_to_clock_s if report.ticks_played else None,
            first_start - wall_to_clock_s if report.ticks_played else None,
            None if stop is None else stop - wall_to_clock_s,
            report.lateness_percentile_ms(99),
        )

    def _release(self, staged: _Staged, *, stop: bool) -> None:
        for cancel in staged.cancels:
            cancel()
        if stop:
            Player(staged.bus, staged.robot, RealClock(), staged.limits).stop()
        staged.bus.close()
        staged.folder.cleanup()
        self.state = "idle"
        self.stopped.clear()


def play_part(
    performer: Performer, staged: _Staged, clock: StoppableClock, first_start_s: float
) -> StreamReport:
    """The one place a performer uses the player: its part from the staged pose, first START at
    ``first_start_s`` on ``clock``; servos left holding."""
    last = [-PROGRESS_PERIOD_S]
    events = f"{show_key(staged.show_id)}/progress/{performer.name}"
    approach_s = staged.performance.approach_s

    def progress(p: PlayProgress) -> None:
        if p.time_s - last[0] >= PROGRESS_PERIOD_S or p.tick == p.ticks:
            last[0] = p.time_s
            message = PartProgress(performer.name, p.time_s - approach_s, p.duration_s - approach_s)
            performer.network.publish(events, encode(message))

    player = Player(
        staged.bus, staged.robot, clock, staged.limits, PlayOptions(), on_progress=progress
    )
    report = player.play(staged.performance.ticks, staged.start_pose, start_at_s=first_start_s)
    player.leave(report.outcome)
    return report


def _real_clock(bus: ServoBus) -> Clock:
    clock = bus.clock
    if not isinstance(clock, RealClock):
        raise ChoreoError("a show runs on the wall clock: drop clock=virtual from the sim:// URL")
    return clock


def wire_summary(wire: WireTrace, since_s: float) -> str:
    """One line on how the emulated servos were left: stopped, and nothing started after."""
    stop = wire.last_stop_s(since_s)
    if stop is None:
        return "emulated bus: no MOVE_STOP on the wire (the part ran to its end)"
    later = [m for m in wire.moves if m.time_s > stop]
    return f"emulated bus: MOVE_STOP on the wire; {len(later)} move(s) started after it" + (
        "" if later else ": every servo stopped"
    )
