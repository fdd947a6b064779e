"""``choreo show``: the conductor.

In order: hold the show's liveliness token and beat its heartbeat (performers stop if either
goes), wait for every named performer and refuse two of one name or one another show holds,
measure each one's clock against this one (refusing past the show's bound), stage every part
with this run's ticket and refuse unless every preflight passed, pick one start instant far
enough ahead for every approach, tell each performer that instant on its own clock, cue the song
on it, then follow the parts to their end. Ctrl-C, or a part that aborts or is lost when the show
says ``on_abort: stop``, sends one signed stop that every performer hears.
"""

from __future__ import annotations

import math
import queue
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field

from choreo.errors import ChoreoError
from choreo.motion.motion_file import load_motion
from choreo.show.clock_offset import ROUND_TRIPS, ClockOffset, exceeds, measure
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
    Stop,
    decode,
    encode,
)
from choreo.show.names import name_from
from choreo.show.network import Network, name_of
from choreo.show.showfile import OnAbort, Show
from choreo.show.staging import pack
from choreo.show.ticket import new_ticket, signature

BEAT_PERIOD_S = 0.1  # the heartbeat: a performer stops after DEFAULT_MAX_SILENCE_S without one
REMEASURE_PERIOD_S = 1.0  # during the show, each clock is measured again this often
REMEASURE_ROUND_TRIPS = 4  # a few: between them the conductor does not hear its events
FINISH_GRACE_S = 5.0  # past the planned end, a part that said nothing counts as lost
STOP_REPLIES_S = 2.0  # after a stop, how long to wait for the parts to say they stopped
INTERRUPTED = "Ctrl-C at the conductor"  # the stop's reason (SIGTERM is Ctrl-C too)


@dataclass(frozen=True)
class ConductorOptions:
    wait_s: float = 10.0  # for every performer to appear
    stage_timeout_s: float = 60.0  # to unpack, plan and preflight a part
    lead_s: float = 0.5  # from telling the start instant to the earliest first START
    dry_run: bool = False  # stage and preflight, then release: nothing moves


@dataclass(frozen=True)
class PartResult:
    performer: str
    robot: str
    clock: ClockOffset
    offset_s: float
    start_s: float  # its motion's t=0, conductor's clock
    outcome: PartOutcome
    reason: str
    finished: Finished | None  # its own word (None: lost, or a dry run)
    drift_s: float | None = None  # its clock offset's change from the start to the last measure

    @property
    def first_start_s(self) -> float | None:
        """Its first START on the conductor's clock (its own, corrected by the offset)."""
        if self.finished is None or self.finished.first_start_s is None:
            return None
        return self.finished.first_start_s - self.clock.offset_s


@dataclass(frozen=True)
class ShowReport:
    show: str
    start_s: float  # the show's instant, conductor's wall clock
    parts: tuple[PartResult, ...]
    stop_sent_s: float | None  # when the conductor sent a stop
    stop_reason: str
    called_at_s: float  # when the conductor began
    interrupted: bool = False  # Ctrl-C (or SIGTERM) at the conductor stopped it

    @property
    def completed(self) -> bool:
        return all(p.outcome in (PartOutcome.COMPLETED, PartOutcome.STAGED) for p in self.parts)

    def first_start_spread_s(self) -> float | None:
        """First to last first START, each less its part's offset (on the conductor's clock)."""
        starts = [p.first_start_s - p.offset_s for p in self.parts if p.first_start_s is not None]
        return max(starts) - min(starts) if len(starts) == len(self.parts) else None


@dataclass(frozen=True)
class Armed:
    """One performer's line in the status table shown before GO."""

    performer: str
    robot: str
    clock: ClockOffset
    approach_s: float
    duration_s: float
    unchecked: tuple[str, ...]  # what its transport cannot check (preflight passed otherwise)


Say = Callable[[str], None]
OnProgress = Callable[[PartProgress], None]
# Shown every performer's status once all are staged; returns at GO (raises to call it off).
OnArmed = Callable[[list[Armed]], None]


class Conductor:
    def __init__(
        self,
        network: Network,
        show: Show,
        say: Say,
        options: ConductorOptions = ConductorOptions(),
    ):
        self.network, self.show, self.say, self.options = network, show, say, options
        self.show_id = f"{name_from(show.name)}-{uuid.uuid4().hex[:8]}"
        self.ticket = new_ticket()
        self.realm = network.realm
        self.key = self.realm.show(self.show_id)
        self.events: queue.Queue[tuple[str, object]] = queue.Queue()
        self.names = [p.performer for p in show.parts]
        self._beating = threading.Event()

    def performer_key(self, name: str) -> str:
        return self.realm.performer(name)

    def run(
        self,
        on_progress: OnProgress | None = None,
        cue_song: Callable[[float], None] | None = None,
        on_armed: OnArmed | None = None,
    ) -> ShowReport:
        """The whole show; ``on_armed`` (if given) is shown every performer's status once all are
        staged and returns at GO; ``cue_song(start_s)`` is called with the instant (wall clock)
        once every performer has it. Ctrl-C stops every part; the report then says so."""
        called_at = time.time()
        self.network.announce(self.key)
        beat = threading.Thread(target=self._beat, daemon=True)
        beat.start()
        try:
            return self._run(called_at, on_progress, cue_song, on_armed)
        finally:
            self._beating.set()
            joined(beat)

    def _beat(self) -> None:
        """The heartbeat, every BEAT_PERIOD_S until the run ends (its own thread)."""
        seq, key = 0, f"{self.key}/beat"
        while not self._beating.is_set():
            self.network.publish(
                key,
                encode(Beat(self.show_id, seq, signature(self.ticket, self.show_id, "beat", seq))),
            )
            seq += 1
            self._beating.wait(BEAT_PERIOD_S)

    def _run(
        self,
        called_at: float,
        on_progress: OnProgress | None,
        cue_song: Callable[[float], None] | None,
        on_armed: OnArmed | None,
    ) -> ShowReport:
        self.network.subscribe(f"{self.key}/events/*", self._on_finished)
        if on_progress is not None:
            self.network.subscribe(
                f"{self.key}/progress/*",
                lambda _k, payload: on_progress(decode(PartProgress, payload)),
            )
        self.wait_for_performers()
        self.network.watch(self.performer_key("*"), self._on_performer)
        self.introduce()
        clocks = self.measure_clocks()
        readiness = self.stage()
        if self.options.dry_run:
            self.send_stop("dry run: nothing plays")
            parts = tuple(
                PartResult(p.performer, readiness[p.performer].robot, clocks[p.performer],
                           p.offset_s, 0.0, PartOutcome.STAGED, "dry run", None)
                for p in self.show.parts
            )  # fmt: skip
            return ShowReport(self.show.name, 0.0, parts, None, "dry run", called_at)
        if on_armed is not None:
            try:
                on_armed(self.armed(clocks, readiness))
            except BaseException:  # Ctrl-C, or no GO: every staged part is dropped
                self.send_stop("the show was called off before GO")
                raise
            clocks = self.measure_clocks()  # again: the wait for GO may have been long
        return self.start_and_follow(self.start_instant(readiness), clocks, readiness, called_at,
                                     cue_song)  # fmt: skip

    # --- before the start ----------------------------------------------------------------------
    def armed(self, clocks: dict[str, ClockOffset], readiness: dict[str, Readiness]) -> list[Armed]:
        return [
            Armed(p.performer, readiness[p.performer].robot, clocks[p.performer],
                  readiness[p.performer].approach_s, readiness[p.performer].duration_s,
                  readiness[p.performer].unchecked)
            for p in self.show.parts
        ]  # fmt: skip

    def wait_for_performers(self) -> None:
        deadline = time.monotonic() + self.options.wait_s
        while True:
            alive = self.network.alive(self.performer_key("*"), timeout_s=0.5)
            present = {name_of(k) for k in alive}
            missing = [n for n in self.names if n not in present]
            if not missing:
                return
            if time.monotonic() >= deadline:
                raise ChoreoError(
                    f"{len(missing)} performer(s) did not appear within "
                    f"{self.options.wait_s:g} s: {', '.join(missing)}; start "
                    f"`choreo perform --name {missing[0]}` on its robot's computer (present: "
                    f"{', '.join(sorted(present)) or 'none'})"
                )
            time.sleep(0.1)

    def introduce(self) -> None:
        """One line per performer: where it dances and what it is doing. A ChoreoError listing
        every name two performers answer to, and every performer another show holds."""
        problems = []
        for name in self.names:
            found = self.network.ask_each(f"{self.performer_key(name)}/info", timeout_s=2.0)
            answers = [decode(Announcement, answer) for answer in found]
            if len(answers) > 1:
                where = " and ".join(f"{a.host} (pid {a.pid}, on {a.transport})" for a in answers)
                problems.append(f"{len(answers)} performers are named {name}, on {where}: "
                                "give each its own --name")  # fmt: skip
                continue
            for who in answers:
                if who.show_id and who.show_id != self.show_id:
                    problems.append(f"{name} on {who.host} is busy with show {who.show_id} "
                                    "(another conductor holds it)")  # fmt: skip
                else:
                    self.say(f"{who.name}: found on {who.host}, on {who.transport}, {who.state}")
        if problems:
            raise ChoreoError("refusing to start the show:\n  " + "\n  ".join(problems))

    def measure_clocks(self) -> dict[str, ClockOffset]:
        clocks, problems = {}, []
        bound_ms = self.show.max_clock_offset_s * 1000
        for name in self.names:
            offset = self.measure_clock(name, within_s=self.show.max_clock_offset_s)
            if offset is None:
                problems.append(f"{name}: did not answer the clock round trips")
                continue
            clocks[name] = offset
            if exceeds(offset, self.show.max_clock_offset_s):
                problems.append(
                    f"{name}: its clock is {offset.describe()} against this computer's, over "
                    f"the show's bound of {bound_ms:g} ms; synchronise the clocks "
                    "(chrony/NTP, or PTP)"
                )
        if problems:
            raise ChoreoError("refusing to start the show:\n  " + "\n  ".join(problems))
        return clocks

    def measure_clock(
        self, name: str, rounds: int = ROUND_TRIPS, within_s: float | None = None
    ) -> ClockOffset | None:
        def ask_time() -> float | None:
            reply = self.network.ask(f"{self.performer_key(name)}/clock", timeout_s=1.0)
            return None if reply is None else decode(ClockReading, reply).time_s

        return measure(ask_time, rounds, within_s=within_s)

    def stage(self) -> dict[str, Readiness]:
        """Every part staged; a ChoreoError listing every problem of every robot otherwise."""
        requests = {
            f"{self.performer_key(p.performer)}/stage": encode(
                pack(self.show_id, self.ticket, load_motion(p.motion))
            )
            for p in self.show.parts
        }
        answers = self.network.ask_all(requests, self.options.stage_timeout_s)
        readiness, problems = {}, []
        for part in self.show.parts:
            answer = answers[f"{self.performer_key(part.performer)}/stage"]
            if answer is None:
                problems.append(f"{part.performer}: no answer to its part in "
                                f"{self.options.stage_timeout_s:g} s")  # fmt: skip
                continue
            ready = decode(Readiness, answer)
            readiness[part.performer] = ready
            who = f"{part.performer} ({ready.robot})" if ready.robot else part.performer
            problems += [f"{who}: {problem}" for problem in ready.problems]
            if ready.ok and ready.unchecked:
                self.say(f"{who}: its transport cannot check {', '.join(ready.unchecked)}")
        if problems:
            self.send_stop("refused to start")
            raise ChoreoError("refusing to start the show:\n  " + "\n  ".join(problems))
        for part in self.show.parts:
            ready = readiness[part.performer]
            self.say(f"{part.performer} ({ready.robot}): ready, {ready.duration_s:.1f} s part "
                     f"after a {ready.approach_s:.1f} s approach")  # fmt: skip
        return readiness

    def start_instant(self, readiness: dict[str, Readiness]) -> float:
        """Late enough that every approach (before its part's offset) begins after the lead."""
        ahead_s = max(readiness[p.performer].approach_s - p.offset_s for p in self.show.parts)
        return time.time() + self.options.lead_s + max(ahead_s, 0.0)

    def go(self, start_s: float, clocks: dict[str, ClockOffset]) -> None:
        requests = {
            f"{self.performer_key(p.performer)}/go": encode(
                Go(self.show_id, start_s + p.offset_s + clocks[p.performer].offset_s, self.ticket)
            )
            for p in self.show.parts
        }
        answers = self.network.ask_all(requests, self.options.lead_s)
        problems = []
        for key, answer in answers.items():
            name = name_of(key.removesuffix("/go"))
            if answer is None:
                problems.append(f"{name}: no answer to the start")
            elif not (taken := decode(Answer, answer)).ok:
                problems.append(f"{name}: refused the start: {taken.problem}")
        if problems:
            self.send_stop("a performer did not take the start")
            raise ChoreoError("show stopped:\n  " + "\n  ".join(problems))
        self.say(
            f"every performer took the start: the show begins in {start_s - time.time():.1f} s"
        )

    # --- during the show -----------------------------------------------------------------------
    def _measure_again(
        self,
        start_s: float,
        outcomes: dict[str, object],
        later: dict[str, ClockOffset],
        done: threading.Event,
    ) -> None:
        """Each playing performer's clock measured again every REMEASURE_PERIOD_S, into
        ``later``, until ``done`` (its own thread: the main one stays where Ctrl-C reaches it).
        The first time once every part's first START is past, so the round trips' work in the
        performers' Zenoh threads never sits at the instant the spread is measured by."""
        last_first_start_s = start_s + max(p.offset_s for p in self.show.parts)
        wait_s = max(REMEASURE_PERIOD_S, last_first_start_s - time.time() + REMEASURE_PERIOD_S / 4)
        while not done.wait(wait_s):
            for name in self.names:
                if name not in outcomes and not done.is_set():
                    offset = self.measure_clock(name, REMEASURE_ROUND_TRIPS)
                    if offset is not None:  # unanswered: its part's end will tell
                        later[name] = offset
            wait_s = REMEASURE_PERIOD_S

    def _on_finished(self, _key: str, payload: bytes) -> None:
        self.events.put(("finished", decode(Finished, payload)))

    def _on_performer(self, key: str, alive: bool) -> None:
        if not alive:
            self.events.put(("lost", name_of(key)))

    def send_stop(self, reason: str) -> float:
        signed = signature(self.ticket, self.show_id, "stop", reason)
        self.network.publish(f"{self.key}/stop", encode(Stop(self.show_id, reason, signed)))
        return time.time()

    def start_and_follow(
        self,
        start_s: float,
        clocks: dict[str, ClockOffset],
        readiness: dict[str, Readiness],
        called_at: float,
        cue_song: Callable[[float], None] | None = None,
    ) -> ShowReport:
        """Send GO, then follow the parts to their end; Ctrl-C from GO on stops them all, and the
        report says so. Each clock is measured again meanwhile, in a thread of its own."""
        end_s = start_s + max(
            p.offset_s + readiness[p.performer].duration_s for p in self.show.parts
        )
        following = _Following(end_s + FINISH_GRACE_S, math.ceil(start_s - time.time()))
        later: dict[str, ClockOffset] = {}  # each clock as measured again during the show
        watcher: threading.Thread | None = None
        interrupted = False
        # one try from GO to the end: a Ctrl-C anywhere between (a stop signal comes as one the
        # instant a performer says it plays) stops every part, never escapes without a report
        try:
            try:
                self.go(start_s, clocks)
                if cue_song is not None:
                    cue_song(start_s)
                watcher = threading.Thread(
                    target=self._measure_again,
                    args=(start_s, following.outcomes, later, following.measuring_done),
                    daemon=True,
                )
                watcher.start()
            except KeyboardInterrupt:  # some performers may have the start already: stop them
                interrupted = True
            self._await_parts(start_s, following, interrupted)
        finally:
            following.measuring_done.set()
            if watcher is not None:
                joined(watcher)
        parts = []
        for part in self.show.parts:
            outcome, reason, finished = following.outcomes.get(
                part.performer, (PartOutcome.LOST, "no word from it after the show's end", None)
            )
            clock, last = clocks[part.performer], later.get(part.performer)
            parts.append(
                PartResult(part.performer, readiness[part.performer].robot, clock,
                           part.offset_s, start_s + part.offset_s, outcome, reason, finished,
                           None if last is None else last.offset_s - clock.offset_s)
            )  # fmt: skip
        return ShowReport(self.show.name, start_s, tuple(parts), following.stop_sent_s,
                          following.stop_reason, called_at, following.interrupted)  # fmt: skip

    def _await_parts(self, start_s: float, following: _Following, interrupted: bool) -> None:
        """Every part's end, as its events come (or the deadline), saying the countdown;
        Ctrl-C stops every part, and so does a part that fails when the show says so."""
        while len(following.outcomes) < len(self.names) and time.time() < following.deadline_s:
            # Ctrl-C may come while an event is being told as well as while waiting for one
            try:
                if interrupted:
                    interrupted = False
                    raise KeyboardInterrupt
                self._count_down(start_s, following)
                try:
                    kind, what = self.events.get(timeout=0.1)
                except queue.Empty:
                    continue
                self._on_event(following, kind, what)
            except KeyboardInterrupt:
                following.interrupted = True
                self._stop_parts(following, INTERRUPTED)
                following.deadline_s = time.time() + STOP_REPLIES_S
                self.say(f"{INTERRUPTED}: stopping every performer")

    def _on_event(self, following: _Following, kind: str, what: object) -> None:
        """Note a part's end; a failed part stops the others when the show says so."""
        failed = self._heard(following, kind, what)
        if failed and following.stop_sent_s is None and self.show.on_abort is OnAbort.STOP:
            self._stop_parts(following, f"{failed} aborted or was lost (on_abort: stop)")
            following.deadline_s = min(following.deadline_s, time.time() + STOP_REPLIES_S)

    def _count_down(self, start_s: float, following: _Following) -> None:
        """Say each whole second left before the show's instant (until a stop)."""
        to_go = math.ceil(start_s - time.time())
        if 0 < to_go < following.counted and following.stop_sent_s is None:
            self.say(f"the show begins in {to_go} s")
            following.counted = to_go

    def _heard(self, following: _Following, kind: str, what: object) -> str:
        """Note a part's end (a performer's Finished, or its token lost); the name of the
        performer whose part failed by it ("" when none did)."""
        outcomes = following.outcomes
        if kind == "lost" and what in self.names and what not in outcomes:
            outcomes[what] = (PartOutcome.LOST, "its liveliness token vanished", None)
            self.say(f"{what}: lost (its liveliness token vanished)")
            return str(what)
        if isinstance(what, Finished) and what.performer in self.names:
            outcomes[what.performer] = (what.outcome, what.reason, what)
            self.say(f"{what.performer}: {what.outcome.value}"
                     f"{': ' + what.reason if what.reason else ''}")  # fmt: skip
            return what.performer if what.outcome is PartOutcome.ABORTED else ""
        return ""

    def _stop_parts(self, following: _Following, reason: str) -> None:
        following.measuring_done.set()  # no more round trips: the stop goes first
        following.stop_reason = reason
        following.stop_sent_s = self.send_stop(reason)


@dataclass
class _Following:
    """What ``Conductor.start_and_follow`` has heard so far."""

    deadline_s: float  # wall clock: a part not heard of by then counts as lost
    counted: int  # the countdown's last whole second said
    outcomes: dict[str, tuple[PartOutcome, str, Finished | None]] = field(default_factory=dict)
    stop_sent_s: float | None = None
    stop_reason: str = ""
    interrupted: bool = False  # Ctrl-C (or SIGTERM) at the conductor stopped it
    measuring_done: threading.Event = field(default_factory=threading.Event)


def joined(thread: threading.Thread, grace_s: float = 2.0) -> None:
    """``thread`` joined: it has been told to end, and does within a beat. A Ctrl-C meanwhile
    waits ``grace_s`` more rather than losing the show's report, made or being made, after
    every part was stopped; a second Ctrl-C in that wait is not held back."""
    if thread.ident is None:  # never started
        return
    try:
        thread.join()
    except KeyboardInterrupt:
        thread.join(grace_s)
