"""``choreo perform``: one robot's computer in a show.

It announces itself (a liveliness token, and ``info``), answers clock round trips at once (in
Zenoh's thread), and takes the rest in its main thread, one at a time: a staged part is unpacked,
compiled and preflighted on its own bus (the answer lists every problem); ``go`` plays it with
its first START at the instant the conductor picked.

Only the conductor that staged the part moves it: the part came with that conductor's ticket
(:mod:`choreo.show.ticket`); a start must carry it, a stop and a heartbeat must be signed with it,
and while a part is held any other show's stage is answered "busy with show X". The servos stop
at once on the conductor's stop, when its liveliness token vanishes, or when its heartbeat has
been silent for ``max_silence_s`` (a frozen conductor, a cut network): the player's clock wakes
from its wait and the player sends MOVE_STOP.
"""

from __future__ import annotations

import logging
import os
import queue
import socket
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
    Answer,
    Beat,
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
from choreo.show.network import Network, Request
from choreo.show.staging import unpack
from choreo.show.ticket import signed

log = logging.getLogger(__name__)

PROGRESS_PERIOD_S = 0.25
WAIT_STEP_S = 0.1  # how often the idle loop looks at the stop flag
# A heartbeat silent this long stops the servos. The conductor beats every BEAT_PERIOD_S
# (choreo.show.conductor): 0.4 s is four beats lost in a row, and the watchdog looks every
# WATCHDOG_PERIOD_S, so the servos stop within half a second of the last beat.
DEFAULT_MAX_SILENCE_S = 0.4
WATCHDOG_PERIOD_S = 0.05  # few wake-ups beside the player: 400 + 50 ms stays under 500

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


@dataclass(frozen=True)
class Holder:
    """The conductor that holds this performer: its show and the ticket it staged with."""

    show_id: str
    ticket: str


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
    released: bool = False


class Performer:
    def __init__(
        self,
        network: Network,
        name: str,
        open_bus: OpenBus,
        transport: str,
        say: Callable[[str], None],
        max_silence_s: float = DEFAULT_MAX_SILENCE_S,
    ):
        self.network, self.name, self.open_bus = network, name, open_bus
        self.transport, self.say, self.max_silence_s = transport, say, max_silence_s
        self.state, self.robot = "idle", ""
        self.requests: queue.Queue[tuple[str, Request]] = queue.Queue()
        self.stopped = threading.Event()
        self.stop_reason = ""
        self.holder: Holder | None = None
        self.conductor_alive = False
        self.last_beat_s = 0.0  # monotonic clock
        self.last_seq = -1
        self._closing = threading.Event()
        key = network.realm.performer(name)
        network.serve(f"{key}/info", lambda r: r.reply(encode(self.announcement())))
        network.serve(f"{key}/clock", lambda r: r.reply(encode(ClockReading(time.time()))))
        network.serve(f"{key}/stage", self._on_stage)
        network.serve(f"{key}/go", self._on_go)
        network.announce(key)
        self._watchdog = threading.Thread(target=self._watch_heartbeat, daemon=True)
        self._watchdog.start()

    def announcement(self) -> Announcement:
        holder = self.holder
        return Announcement(
            self.name,
            self.transport,
            self.robot,
            self.state,
            socket.gethostname(),
            os.getpid(),
            holder.show_id if holder else "",
        )

    def stop(self, reason: str) -> None:
        """From any thread: stop the servos of the part staged or playing now."""
        if not self.stopped.is_set():
            self.stop_reason = reason
            self.stopped.set()

    # --- what arrives in Zenoh's threads -------------------------------------------------------
    def _on_stage(self, request: Request) -> None:
        """A part: queued for the main loop, unless another show holds this performer."""
        busy = self._busy_for(request.payload)
        if busy:
            request.reply(encode(Readiness(self.name, self.robot, (busy,))))
        else:
            self.requests.put(("stage", request))

    def _busy_for(self, payload: bytes) -> str:
        """Why a part cannot be staged now ("" if it can)."""
        try:
            part = decode(StagedPart, payload)
        except ChoreoError as error:
            return str(error)
        holder = self.holder
        if holder is not None and (part.show_id, part.ticket) != (holder.show_id, holder.ticket):
            return f"busy with show {holder.show_id}"
        if self.state == "playing":
            return f"busy with show {part.show_id}: still playing its part"
        return ""

    def _on_go(self, request: Request) -> None:
        problem = self._refusal_of(request.payload)
        if problem:
            request.reply(encode(Answer(self.name, problem)))
            self.say(f"refused a start: {problem}")
        else:
            self.requests.put(("go", request))

    def _refusal_of(self, payload: bytes) -> str:
        """Why a start cannot be taken ("" if it can)."""
        try:
            go = decode(Go, payload)
        except ChoreoError as error:
            return str(error)
        holder = self.holder
        if holder is None:
            return "no part is staged"
        if self.state == "playing":
            return f"busy with show {holder.show_id}: already playing"
        if go.show_id != holder.show_id:
            return f"the staged part is show {holder.show_id}'s, not {go.show_id}'s"
        if go.ticket != holder.ticket:
            return f"the start did not come from the conductor that staged show {go.show_id}"
        if not self.conductor_alive or self._silence_s() > self.max_silence_s:
            return f"no live conductor holds show {go.show_id}"
        return ""

    def _on_conductor(self, _key: str, alive: bool) -> None:
        self.conductor_alive = alive
        if not alive:
            self.stop("lost the conductor (its liveliness token vanished)")

    def _on_stop(self, _key: str, payload: bytes) -> None:
        holder = self.holder
        try:
            stop = decode(Stop, payload)
        except ChoreoError as error:
            log.info("an unreadable stop: %s", error)
            return
        if holder is None or stop.show_id != holder.show_id:
            return
        if not signed(holder.ticket, stop.signature, stop.show_id, "stop", stop.reason):
            self.say(f"ignored a stop for show {stop.show_id} not signed by its conductor")
            return
        self.stop(f"stopped by the conductor: {stop.reason}")

    def _on_beat(self, _key: str, payload: bytes) -> None:
        holder = self.holder
        try:
            beat = decode(Beat, payload)
        except ChoreoError:
            return
        if holder is None or beat.show_id != holder.show_id or beat.seq <= self.last_seq:
            return  # another show's, or a replay
        if signed(holder.ticket, beat.signature, beat.show_id, "beat", beat.seq):
            self.last_seq, self.last_beat_s = beat.seq, time.monotonic()

    def _silence_s(self) -> float:
        return time.monotonic() - self.last_beat_s

    def _watch_heartbeat(self) -> None:
        """Stop the part of a conductor silent past ``max_silence_s`` (its own thread)."""
        while not self._closing.wait(WATCHDOG_PERIOD_S):
            silence_s = self._silence_s()
            if self.holder is not None and silence_s > self.max_silence_s:
                self.stop(
                    f"lost the conductor (no heartbeat for {silence_s * 1000:.0f} ms, over "
                    f"{self.max_silence_s * 1000:.0f} ms)"
                )

    def close(self) -> None:
        """Ends ``serve_forever`` (within WAIT_STEP_S, after a part being played) and the
        watchdog."""
        self._closing.set()

    # --- the main loop -------------------------------------------------------------------------
    def serve_forever(self) -> None:
        """Take parts and play them until Ctrl-C (KeyboardInterrupt, servos stopped first) or
        ``close`` from another thread."""
        staged: _Staged | None = None
        try:
            while not self._closing.is_set():
                try:
                    kind, request = self.requests.get(timeout=WAIT_STEP_S)
                except queue.Empty:
                    if staged is not None and self.stopped.is_set():
                        self.say(f"{self.stop_reason}: part dropped, servos stopped")
                        self._release(staged, stop=True)
                        staged = None
                    continue
                if kind == "stage":
                    busy = self._busy_for(request.payload)
                    if busy:  # another show took it since the part was queued
                        request.reply(encode(Readiness(self.name, self.robot, (busy,))))
                        continue
                    if staged is not None:  # its own conductor staged it again
                        self._release(staged, stop=False)
                    staged = self._stage(request)
                elif staged is None or self._refusal_of(request.payload):
                    problem = self._refusal_of(request.payload) or "no part is staged"
                    request.reply(encode(Answer(self.name, problem)))
                else:
                    try:
                        self._play(staged, request)
                    finally:
                        self._release(staged, stop=False)
                        staged = None
        finally:
            self.close()
            if staged is not None:
                self._release(staged, stop=True)

    def _stage(self, request: Request) -> _Staged | None:
        self.stopped.clear()
        part = decode(StagedPart, request.payload)  # read once already: _busy_for
        conductor = self.network.realm.show(part.show_id)
        if not self.network.alive(conductor, timeout_s=1.0):
            self._refuse(request, "", f"no conductor holds show {part.show_id} (no liveliness "
                         "token): a part is taken only from a running `choreo show`")  # fmt: skip
            return None
        folder = tempfile.TemporaryDirectory(prefix="choreo-part-")
        try:
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
        self.last_seq, self.last_beat_s = -1, time.monotonic()  # the silence counts from here
        self.holder = Holder(part.show_id, part.ticket)
        staged.cancels.append(self.network.watch(conductor, self._on_conductor))
        staged.cancels.append(self.network.subscribe(f"{conductor}/stop", self._on_stop))
        staged.cancels.append(self.network.subscribe(f"{conductor}/beat", self._on_beat))
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
        request.reply(encode(Answer(self.name)))
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
        self.say(
            f"part {finished.outcome.value}{': ' + finished.reason if finished.reason else ''}"
        )
        events = f"{self.network.realm.show(staged.show_id)}/events/{self.name}"
        self._release(staged, stop=False)  # free before the conductor hears: its next cue
        self.network.publish(events, encode(finished))
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
        """How the part ended: its STARTs as this computer's clock read them when their bytes
        were written (any transport), and on an emulated bus (``wire``) its MOVE_STOP."""
        outcome, reason = PartOutcome(report.outcome.value), report.reason
        if report.outcome is Outcome.ABORTED and self.stopped.is_set():  # the clock's abort
            outcome, reason = PartOutcome.STOPPED, self.stop_reason
        part_due_s = report.start_time_s + staged.performance.approach_s  # the motion's t=0
        starts = report.start_times
        first = next((s for s in starts if s.deadline_s >= part_due_s - START_SLACK_S), None)
        stop = wire.last_stop_s(began_s) if wire is not None else None
        return Finished(
            self.name,
            outcome,
            reason,
            report.ticks_played,
            report.ticks_total,
            starts[0].written_s - wall_to_clock_s if starts else None,
            first.written_s - wall_to_clock_s if first else None,
            None if stop is None else stop - wall_to_clock_s,
            report.lateness_percentile_ms(99),
            first.late_ms if first else None,
        )

    def _release(self, staged: _Staged, *, stop: bool) -> None:
        if staged.released:
            return
        staged.released = True
        for cancel in staged.cancels:
            cancel()
        if stop:
            Player(staged.bus, staged.robot, RealClock(), staged.limits).stop()
        staged.bus.close()
        staged.folder.cleanup()
        self.state, self.holder, self.conductor_alive = "idle", None, False
        self.stopped.clear()


def play_part(
    performer: Performer, staged: _Staged, clock: StoppableClock, first_start_s: float
) -> StreamReport:
    """The one place a performer uses the player: its part from the staged pose, first START at
    ``first_start_s`` on ``clock``; servos left holding."""
    last = [-PROGRESS_PERIOD_S]
    events = f"{performer.network.realm.show(staged.show_id)}/progress/{performer.name}"
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
