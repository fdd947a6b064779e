"""One pass over a tick list on an absolute clock: the player's deadline loop.

Each tick k: at its deadline it is started (``choreo.play.tick_sending``: a broadcast MOVE_START
of the moves staged before it, or one move frame); right after, tick k+1 is staged (in one
write). Deadlines are absolute from one start time, so nothing drifts. Spare bus time before the
next START goes to health reads (``choreo.play.health``), each with a timeout that ends before
that START. If the host falls a whole tick behind, the servos are re-targeted to where the plan
is now instead of replaying stale ticks.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from choreo.bus.protocol import BYTE_TIME_S, SPECS, Command
from choreo.core.clock import Clock
from choreo.plan.ticks import Tick
from choreo.play.health import HealthReads
from choreo.play.realtime import NOT_ASKED, Scheduling
from choreo.play.report import Outcome, PlayProgress, StartTime, StreamReport
from choreo.play.tick_sending import TickSending

log = logging.getLogger(__name__)

READ_BYTES = SPECS[Command.POS_READ].request_len + 3 + SPECS[Command.POS_READ].read_reply_len + 3


class Stream:
    """The state of one pass over ``ticks``, from the servos at ``start_units``: the first
    START ``lead_s`` after tick 0 can be staged, or at ``start_at_s`` on the clock."""

    def __init__(
        self,
        ticks: list[Tick],
        start_units: np.ndarray,
        *,
        clock: Clock,
        sending: TickSending,
        health: HealthReads,
        lead_s: float,
        start_guard_s: float,
        on_progress: Callable[[PlayProgress], None] | None = None,
        start_at_s: float | None = None,
    ):
        self.ticks, self.clock, self.sending, self.health = ticks, clock, sending, health
        self.start_guard_s = start_guard_s
        self.on_progress = on_progress
        self.previous_units = start_units
        self.current_units = start_units.copy()
        self.lateness_ms: list[float] = []
        self.start_times: list[StartTime] = []
        self.retargeted = 0
        self.bytes_sent = 0
        self.wire_free_s = -np.inf  # when the bytes sent so far will have left the host
        self.played = 0
        self.outcome, self.reason = Outcome.COMPLETED, ""
        # Start once whatever was sent before has left and every servo of tick 0 is staged
        # (through a board: once tick 0's move frame can reach its servos on time).
        sending.bus.drain()
        self.t0 = clock.now() + sending.first_lead_s() + lead_s
        if start_at_s is not None:
            self.t0 = start_at_s
        self.end_s = self.t0

    @property
    def planned_s(self) -> float:
        last = self.ticks[-1] if self.ticks else None
        return (last.start_ms + last.duration_ms) / 1000 if last else 0.0

    def deadline(self, k: int) -> float:
        return self.t0 + self.ticks[k].start_ms / 1000

    def run(self, on_first_start: Callable[[float], None] | None = None) -> None:
        """Play every tick; ``on_first_start`` is told the first START's time before anything
        is sent (the song is cued on it)."""
        if not self.ticks:
            return
        if on_first_start is not None:
            on_first_start(self.t0)
        self.stage(self.ticks[0], all_servos=True)
        k = 0
        while k < len(self.ticks):
            k = self.catch_up(k)
            self.start(k)
            # what the next START needs first (its staged moves fill most of the bus time
            # before it), then the progress callback and health reads in the time that is left
            if k + 1 < len(self.ticks):
                self.stage(self.ticks[k + 1], all_servos=False)
            self.report_progress(k)
            if k + 1 < len(self.ticks):
                self.use_spare_time(k)
            k += 1
        self.clock.sleep_until(self.t0 + self.planned_s)
        self.end_s = self.clock.now()

    def catch_up(self, k: int) -> int:
        """If tick k's time is already over, jump to the tick the plan will be in once every
        servo is re-staged (and the servos' start gap has passed), shortened to end on time.
        Through a board, a link still busy with earlier frames counts as behind too."""
        ticks = self.ticks
        now = self.sending.link_free_s(self.clock.now(), self.wire_free_s)
        if k + 1 >= len(ticks) or now < self.deadline(k + 1):
            return k
        restage_s = self.sending.restage_s()
        ready_ms = math.ceil((now + restage_s + self.start_guard_s - self.t0) * 1000)
        j = k + 1
        while j + 1 < len(ticks) and ready_ms >= ticks[j + 1].start_ms:
            j += 1
        log.warning(
            "fell behind by %.1f ms: re-targeting from tick %d to tick %d",
            (now - self.deadline(k)) * 1000,
            k,
            j,
        )
        self.retargeted += 1
        start_ms = min(ready_ms, ticks[j].end_ms - 1)
        ticks[j] = replace(
            ticks[j],
            start_ms=start_ms,
            duration_ms=ticks[j].end_ms - start_ms,
            staged=(True,) * len(ticks[j].staged),
        )  # re-staged: needs its START
        self.stage(ticks[j], all_servos=True)
        return j

    def start(self, k: int) -> None:
        """Start tick k so that it arrives at the servos on its deadline.

        A tick that changes no target sends nothing: every servo is already there.
        """
        clock, tick, sending = self.clock, self.ticks[k], self.sending
        moves = sending.moves(tick, all_servos=k == 0)
        send_at = self.deadline(k) - sending.start_lead_s(len(moves))
        clock.sleep_until(send_at)  # also for a tick without START: what follows is timed from it
        if moves:
            now = clock.now()
            sent = sending.start(tick, moves)  # first: the bookkeeping can wait, the START not
            written_s = clock.now()
            leaves_s = sending.link_free_s(now, self.wire_free_s)
            self.lateness_ms.append((leaves_s - send_at) * 1000)
            self.start_times.append(StartTime(self.deadline(k), send_at, written_s))
            self.sent(*sent)
        self.previous_units = self.current_units
        self.current_units = np.asarray(tick.targets_units, dtype=float)
        self.played = k + 1

    def stage(self, tick: Tick, *, all_servos: bool) -> None:
        count = self.sending.stage(tick, all_servos=all_servos)
        if count:
            self.sent(count)

    def use_spare_time(self, k: int) -> None:
        """Health reads until the next START's guard time (never delaying it)."""
        clock, next_start, tick = self.clock, self.deadline(k + 1), self.ticks[k]
        link_s = self.sending.read_link_s
        for _ in range(self.sending.servos):  # bounded: at most one round per tick
            now = clock.now()
            budget = next_start - max(now, self.wire_free_s) - link_s
            fraction = np.clip((now - self.deadline(k)) / (tick.duration_ms / 1000), 0.0, 1.0)
            expected = self.previous_units + fraction * (self.current_units - self.previous_units)
            if not self.health.read(budget, expected):
                return
            self.sent(READ_BYTES)

    def sent(self, count: int, busy_s: float | None = None) -> None:
        """Account for bytes put on the wire: it sends them one after another at 115200 baud
        (``busy_s``: how long they keep a board busy instead)."""
        now = self.clock.now()
        busy_s = count * BYTE_TIME_S if busy_s is None else busy_s
        self.wire_free_s = max(now, self.wire_free_s) + busy_s
        self.bytes_sent += count

    def report_progress(self, k: int) -> None:
        if self.on_progress:
            now = self.clock.now() - self.t0
            bus_use = self.bytes_sent * BYTE_TIME_S / max(now, 1e-3)
            self.on_progress(PlayProgress(now, self.planned_s, k + 1, len(self.ticks), bus_use))

    def finish(self, outcome: Outcome, reason: str) -> None:
        self.outcome, self.reason = outcome, reason
        self.end_s = self.clock.now()

    def report(self, scheduling: Scheduling = NOT_ASKED) -> StreamReport:
        return StreamReport(
            outcome=self.outcome,
            reason=self.reason,
            ticks_played=self.played,
            ticks_total=len(self.ticks),
            retargeted=self.retargeted,
            lateness_ms=tuple(self.lateness_ms),
            start_times=tuple(self.start_times),
            bytes_sent=self.bytes_sent,
            planned_s=self.planned_s,
            elapsed_s=self.end_s - self.t0,
            health=self.health.records,
            start_time_s=self.t0,
            transport=self.sending.bus.capabilities.transport,
            start_skew_ms=self.sending.start_skew_ms(),
            scheduling=scheduling,
        )
