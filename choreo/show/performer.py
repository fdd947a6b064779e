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
from its wait and the player sends MOVE_STOP (:mod:`choreo.show.custody`). When it was written,
and why, goes in the part's report and in one line said here.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import socket
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import Clock, RealClock
from choreo.emulator.trace import START_SLACK_S, WireTrace
from choreo.errors import ChoreoError, SourceError
from choreo.plan.performance import Performance, prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import ServoLimits, preflight, unchecked
from choreo.play.realtime import PLAY_PRIORITY, how_to_allow
from choreo.play.report import Outcome, PlayProgress, StreamReport
from choreo.robot.types import Robot
from choreo.show.custody import (
    DEFAULT_MAX_SILENCE_S,
    Custody,
    CustodyClock,
    CustodyPlayer,
    Holder,
    clock_time,
    stop_summary,
)
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
    StopCause,
    decode,
    encode,
)
from choreo.show.network import Network, Request
from choreo.show.staging import unpack
from choreo.show.ticket import signed

log = logging.getLogger(__name__)

PROGRESS_PERIOD_S = 0.25
WAIT_STEP_S = 0.1  # how often the idle loop looks at its closing flag

# The player's own real-time priority also locks all memory: for a performer (Zenoh's threads
# and arenas) 250 ms and 200 MB on a 2-core PC, while Zenoh's threads stall and the heartbeat
# goes silent past its bound. So a show asks for the priority alone (play_priority).
SHOW_PLAY = PlayOptions(realtime=False)

OpenBus = Callable[[Robot], ServoBus]


@dataclass
class _Staged:
    """A part ready to play: its bus is open, its servos loaded and holding."""

    show_id: str
    robot: Robot
    bus: ServoBus
    performance: Performance
    duration_s: float  # the motion's, after its approach
    start_pose: tuple[float, ...]
    limits: dict[str, ServoLimits]
    folder: tempfile.TemporaryDirectory
    cancels: list[Callable[[], None]]
    released: bool = False


class _Refusal(Exception):
    """Why a part cannot be staged here: every problem, for the conductor to list."""

    def __init__(self, robot: str, *problems: str):
        super().__init__(*problems)
        self.robot, self.problems = robot, problems


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
        # what the main loop takes; None only wakes it (a stop)
        self.requests: queue.Queue[tuple[str, Request | None]] = queue.Queue()
        self.custody: Custody | None = None  # while a conductor holds this performer
        self._closing = False
        key = network.realm.performer(name)
        network.serve(f"{key}/info", lambda r: r.reply(encode(self.announcement())))
        network.serve(f"{key}/clock", lambda r: r.reply(encode(ClockReading(time.time()))))
        network.serve(f"{key}/stage", self._on_stage)
        network.serve(f"{key}/go", self._on_go)
        network.announce(key)

    @property
    def holder(self) -> Holder | None:
        custody = self.custody
        return custody.holder if custody is not None else None

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

    def stop(self, cause: StopCause, reason: str) -> None:
        """From any thread: stop the servos of the part staged or playing now."""
        custody = self.custody
        if custody is not None:
            custody.stop(cause, reason)
            self.requests.put(("stop", None))  # the idle loop drops a staged part at once

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
        custody = self.custody
        if custody is None or not custody.live():
            return f"no live conductor holds show {go.show_id}"
        return ""

    def _on_conductor(self, _key: str, alive: bool) -> None:
        custody = self.custody
        if custody is not None:
            custody.conductor_alive = alive
        if not alive:
            self.stop(
                StopCause.CONDUCTOR_LOST, "lost the conductor (its liveliness token vanished)"
            )

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
        self.stop(StopCause.STOP_MESSAGE, f"stopped by the conductor: {stop.reason}")

    def _on_beat(self, _key: str, payload: bytes) -> None:
        custody = self.custody
        try:
            beat = decode(Beat, payload)
        except ChoreoError:
            return
        if custody is None or beat.show_id != custody.holder.show_id:
            return  # another show's
        if signed(custody.holder.ticket, beat.signature, beat.show_id, "beat", beat.seq):
            custody.beat(beat.seq)

    def close(self) -> None:
        """Ends ``serve_forever`` (within WAIT_STEP_S, after a part being played)."""
        self._closing = True

    # --- the main loop -------------------------------------------------------------------------
    def serve_forever(self) -> None:
        """Take parts and play them until Ctrl-C (KeyboardInterrupt, servos stopped first) or
        ``close`` from another thread."""
        staged: _Staged | None = None
        try:
            while not self._closing:
                kind, request = self._next_request()
                custody = self.custody
                if staged is not None and custody is not None and custody.stopped.is_set():
                    self._release(staged, stop=True)
                    self.say(f"{custody.reason}: part dropped, {stop_summary(custody)}")
                    staged = None
                if request is None:
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

    def _next_request(self) -> tuple[str, Request | None]:
        """The next request, or ("", None) once the held part's silence bound is reached (its
        custody then stopped) or WAIT_STEP_S has passed."""
        custody = self.custody
        wait_s = WAIT_STEP_S
        if custody is not None:
            wait_s = min(wait_s, max(0.0, custody.silent_at() - custody.clock.now()))
        try:
            return self.requests.get(timeout=wait_s)
        except queue.Empty:
            if custody is not None:
                custody.check_silence()
            return "", None

    def _stage(self, request: Request) -> _Staged | None:
        """A part unpacked, planned and preflighted on its own bus, then held for its conductor
        (answered ready); None when it cannot be (answered with every problem)."""
        part = decode(StagedPart, request.payload)  # read once already: _busy_for
        folder = tempfile.TemporaryDirectory(prefix="choreo-part-")
        try:
            staged = self._prepare(part, folder)
        except _Refusal as refusal:
            folder.cleanup()
            self._refuse(request, refusal.robot, *refusal.problems)
            return None
        self._hold(part, staged)
        ready = Readiness(self.name, staged.robot.name, (), staged.performance.approach_s,
                          staged.duration_s, tuple(unchecked(staged.bus)))  # fmt: skip
        request.reply(encode(ready))
        self.say(f"staged {part.motion} for {staged.robot.name}: preflight passed")
        return staged

    def _prepare(self, part: StagedPart, folder: tempfile.TemporaryDirectory) -> _Staged:
        """The part ready to play from ``folder``, its bus open; ``_Refusal`` otherwise."""
        if not self.network.alive(self.network.realm.show(part.show_id), timeout_s=1.0):
            raise _Refusal("", f"no conductor holds show {part.show_id} (no liveliness token): "
                           "a part is taken only from a running `choreo show`")  # fmt: skip
        try:
            # its robot's model check (MuJoCo, a second to import on a Pi) runs only the first
            # time these robot files are staged here: passed, it is remembered (check_cache)
            motion = unpack(part, Path(folder.name))
            compiled = compile_motion(motion)
        except SourceError as error:
            raise _Refusal("", *error.problems) from None
        except ChoreoError as error:
            raise _Refusal("", *str(error).splitlines()) from None
        robot = motion.robot
        try:
            bus = self.open_bus(robot)
        except (ChoreoError, OSError) as error:  # a port that is not there, or busy
            raise _Refusal(robot.name, f"cannot open its bus: {error}") from None
        try:
            _real_clock(bus)
            start_pose, limits = preflight(bus, robot)
        except ChoreoError as error:
            bus.close()
            problems = str(error).removeprefix("refusing to play:").splitlines()
            raise _Refusal(robot.name, *problems) from None
        performance = prepare(compiled, start_pose)
        return _Staged(part.show_id, robot, bus, performance,
                       compiled.trajectory.duration_s, start_pose, limits, folder, [])  # fmt: skip

    def _hold(self, part: StagedPart, staged: _Staged) -> None:
        """The staged part in its conductor's custody: its stop, heartbeat and token heard."""
        conductor = self.network.realm.show(part.show_id)
        self.custody = Custody(
            Holder(part.show_id, part.ticket), _real_clock(staged.bus), self.max_silence_s
        )  # the silence counts from here
        # _prepare has just found its token; the watch's history of it may come after the
        # conductor's start (seen on a busy machine), which must not be refused for that
        self.custody.conductor_alive = True
        staged.cancels.append(self.network.watch(conductor, self._on_conductor))
        staged.cancels.append(self.network.subscribe(f"{conductor}/stop", self._on_stop))
        staged.cancels.append(self.network.subscribe(f"{conductor}/beat", self._on_beat))
        self.state, self.robot = "staged", staged.robot.name

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
        custody = self.custody
        assert custody is not None  # held from the staging until _release
        with play_priority() as priority:
            report = play_part(self, staged, custody, CustodyClock(clock, custody), first_start)
        if not priority:
            self.say(f"normal priority: a busy computer can make STARTs late; {how_to_allow()}")
        emulator = staged.bus.emulator
        wire = WireTrace.of(emulator) if emulator is not None else None
        finished = self._finished(staged, report, began_s, wall_to_clock_s, wire)
        self.say(
            f"part {finished.outcome.value}{': ' + finished.reason if finished.reason else ''}"
        )
        events = f"{self.network.realm.show(staged.show_id)}/events/{self.name}"
        self._release(staged, stop=False)  # free before the conductor hears: its next cue
        self.network.publish(events, encode(finished))
        if custody.servos_stopped_s is not None:
            self.say(stop_summary(custody))
        if wire is not None:
            self.say(wire_summary(wire, began_s, wall_to_clock_s))
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
        custody = self.custody
        request = custody.request if custody is not None else None
        if report.outcome is Outcome.ABORTED and request is not None:  # the clock's abort
            outcome, reason = PartOutcome.STOPPED, request.reason
        written = custody.servos_stopped_s if custody is not None else None
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
            None if written is None else written - wall_to_clock_s,
            request.cause if request is not None else None,
        )

    def _release(self, staged: _Staged, *, stop: bool) -> None:
        if staged.released:
            return
        staged.released = True
        for cancel in staged.cancels:
            cancel()
        custody = self.custody
        if stop:
            Player(staged.bus, staged.robot, RealClock(), staged.limits).stop()
            if custody is not None:
                custody.servos_stopped()
        staged.bus.close()
        staged.folder.cleanup()
        self.state, self.custody = "idle", None


@contextlib.contextmanager
def play_priority() -> Iterator[bool]:
    """SCHED_FIFO at the player's priority for the calling thread where permitted (not the
    memory locking: SHOW_PLAY); yields whether it was got."""
    previous = (os.sched_getscheduler(0), os.sched_getparam(0))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PLAY_PRIORITY))
        raised = True
    except OSError:  # EPERM: not permitted
        raised = False
    try:
        yield raised
    finally:
        if raised:
            os.sched_setscheduler(0, *previous)


def play_part(
    performer: Performer,
    staged: _Staged,
    custody: Custody,
    clock: CustodyClock,
    first_start_s: float,
) -> StreamReport:
    """The one place a performer uses the player: its part from the staged pose, first START at
    ``first_start_s`` on ``clock``; servos left holding."""
    last = [-PROGRESS_PERIOD_S]
    events = f"{performer.network.realm.show(staged.show_id)}/progress/{performer.name}"
    approach_s = staged.performance.approach_s

    def progress(p: PlayProgress) -> None:
        # Once a tick is started and the next staged: give way to another performer on this
        # computer whose START is due now (same real-time priority, woken at the same instant);
        # with several on fewer cores they would otherwise start one after another.
        os.sched_yield()
        if p.time_s - last[0] >= PROGRESS_PERIOD_S or p.tick == p.ticks:
            last[0] = p.time_s
            message = PartProgress(performer.name, p.time_s - approach_s, p.duration_s - approach_s)
            performer.network.publish(events, encode(message))

    player = CustodyPlayer(
        custody, staged.bus, staged.robot, clock, staged.limits, SHOW_PLAY, on_progress=progress
    )
    report = player.play(staged.performance.ticks, staged.start_pose, start_at_s=first_start_s)
    player.leave(report.outcome)
    return report


def _real_clock(bus: ServoBus) -> Clock:
    clock = bus.clock
    if not isinstance(clock, RealClock):
        raise ChoreoError("a show runs on the wall clock: drop clock=virtual from the sim:// URL")
    return clock


def wire_summary(wire: WireTrace, since_s: float, wall_to_clock_s: float) -> str:
    """One line on how the emulated servos were left: stopped (when, wall clock), and nothing
    started after."""
    stop = wire.last_stop_s(since_s)
    if stop is None:
        return "emulated bus: no MOVE_STOP on the wire (the part ran to its end)"
    later = [m for m in wire.moves if m.time_s > stop]
    return (
        f"emulated bus: MOVE_STOP on the wire at {clock_time(stop - wall_to_clock_s)}; "
        f"{len(later)} move(s) started after it" + ("" if later else ": every servo stopped")
    )
