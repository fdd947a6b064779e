"""A performer in a conductor's custody: who holds it, and when its servos must stop.

A conductor holds a performer from the part it staged until the part ends. The servos stop on its
signed stop, when its liveliness token vanishes, or when its heartbeat has been silent for
``max_silence_s`` (a frozen conductor, a cut network). The first of these wins and is kept with
its cause, and the instant the MOVE_STOP bytes were written is noted.

The silence is watched by whoever waits: the player's clock (``CustodyClock``) never sleeps past
the instant the silence would exceed the bound, and the performer's idle loop waits no longer
either. So a silent conductor stops the servos at that instant, not at the next look of a
polling thread, and nothing that runs in Zenoh's threads has to reach the player in time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime

from choreo.core.clock import Clock
from choreo.errors import PlaybackAborted
from choreo.play.player import Player
from choreo.show.messages import StopCause

# A heartbeat silent this long stops the servos. The conductor beats every BEAT_PERIOD_S
# (choreo.show.conductor): 0.4 s is four beats lost in a row; the stop follows at once, so a
# conductor that goes silent just after a beat has its robots stopped within half a second.
DEFAULT_MAX_SILENCE_S = 0.4


@dataclass(frozen=True)
class Holder:
    """The conductor that holds this performer: its show and the ticket it staged with."""

    show_id: str
    ticket: str


@dataclass(frozen=True)
class StopRequest:
    """Why the servos of a held part stop, and when that was decided (custody's clock)."""

    cause: StopCause
    reason: str
    at_s: float


class Custody:
    """One held part's stop state, shared by Zenoh's threads (beats, stops, liveliness) and the
    performer's (the player's waits). Times on ``clock`` (monotonic)."""

    def __init__(self, holder: Holder, clock: Clock, max_silence_s: float):
        self.holder, self.clock, self.max_silence_s = holder, clock, max_silence_s
        self.conductor_alive = False  # its liveliness token, as last heard
        self.last_beat_s = clock.now()  # the silence counts from the staging
        self.last_seq = -1
        self.stopped = threading.Event()
        self.request: StopRequest | None = None
        self.servos_stopped_s: float | None = None  # when the MOVE_STOP bytes were written
        self._lock = threading.Lock()

    def beat(self, seq: int) -> None:
        """A heartbeat whose signature was checked; older or replayed ones are ignored."""
        with self._lock:
            if seq > self.last_seq:
                self.last_seq, self.last_beat_s = seq, self.clock.now()

    def silence_s(self) -> float:
        return self.clock.now() - self.last_beat_s

    def silent_at(self) -> float:
        """When the silence will exceed the bound, unless a beat comes first."""
        return self.last_beat_s + self.max_silence_s

    def live(self) -> bool:
        """Whether its conductor is there and beating."""
        return self.conductor_alive and self.clock.now() < self.silent_at()

    def stop(self, cause: StopCause, reason: str) -> None:
        """From any thread: the servos must stop (the first request is the one kept)."""
        with self._lock:
            if self.request is None:
                self.request = StopRequest(cause, reason, self.clock.now())
        self.stopped.set()

    def check_silence(self) -> bool:
        """Stop if the heartbeat has been silent past the bound; whether the part is stopped."""
        silent_at = self.silent_at()
        if self.clock.now() >= silent_at and not self.stopped.is_set():
            self.stop(
                StopCause.SILENCE,
                f"lost the conductor (no heartbeat for {self.max_silence_s * 1000:.0f} ms)",
            )
        return self.stopped.is_set()

    @property
    def reason(self) -> str:
        return self.request.reason if self.request is not None else ""

    def servos_stopped(self) -> None:
        """The MOVE_STOP bytes have been written (the first time only counts)."""
        if self.servos_stopped_s is None:
            self.servos_stopped_s = self.clock.now()


def stop_summary(custody: Custody) -> str:
    """One line on a show's stop: why, when its MOVE_STOP bytes were written (wall clock, to the
    microsecond) and how long after the conductor's last heartbeat."""
    written_s = custody.servos_stopped_s
    assert written_s is not None
    cause = custody.request.cause.value if custody.request is not None else "at this performer"
    since_beat_ms = (written_s - custody.last_beat_s) * 1000
    wall_s = time.time() - (custody.clock.now() - written_s)
    return (
        f"servos stopped ({cause}): MOVE_STOP written at {clock_time(wall_s)}, "
        f"{since_beat_ms:.0f} ms after the conductor's last heartbeat"
    )


def clock_time(wall_s: float) -> str:
    """A wall-clock instant as this computer's local time of day, to the microsecond."""
    return datetime.fromtimestamp(wall_s).strftime("%H:%M:%S.%f")


class CustodyClock:
    """The player's clock in a show: ``clock``'s time, with waits that end early, raising
    ``PlaybackAborted``, once the custody stops (the player then stops the servos, as after a
    failed health check), and that end on their own at the instant the heartbeat's silence
    exceeds its bound.

    ``block(timeout_s)`` waits until the custody stops or the time is over and says whether it
    stopped; by default ``custody.stopped.wait`` (real time). On a virtual clock, pass one that
    advances the clock instead.

    Unlike RealClock it does not spin the last millisecond before a START: at real-time priority
    the kernel wakes it on time anyway, and performers sharing a computer's cores (a rehearsal
    on one machine) spinning at that priority start one after another, a millisecond apart."""

    def __init__(
        self,
        clock: Clock,
        custody: Custody,
        block: Callable[[float], bool] | None = None,
    ):
        self.clock, self.custody = clock, custody
        self.block = block if block is not None else custody.stopped.wait

    def now(self) -> float:
        return self.clock.now()

    def sleep_until(self, deadline_s: float) -> None:
        custody = self.custody
        while not custody.check_silence():
            now = self.clock.now()
            if now >= deadline_s:
                return
            silent_at = custody.silent_at()
            if silent_at < deadline_s:  # a beat may come before: wake then, and look again
                self.block(max(0.0, silent_at - now))
            elif not self.block(deadline_s - now):
                self.clock.sleep_until(deadline_s)  # only if woken a hair early
        raise PlaybackAborted(custody.reason)


class CustodyPlayer(Player):
    """A player that notes in ``custody`` when its MOVE_STOP bytes were written."""

    def __init__(self, custody: Custody, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.custody = custody

    def stop(self) -> None:
        super().stop()
        self.custody.servos_stopped()
