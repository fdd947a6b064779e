"""A held part stops on its conductor's silence, stop or loss: played by the player on an
emulated arm in virtual time, the heartbeat fed by the clock's own waits. Order and content."""

from __future__ import annotations

import threading

import pytest
from paths import REPO
from play_helpers import Rig

from choreo.bus.protocol import Command
from choreo.core.clock import RealClock, VirtualClock
from choreo.errors import PlaybackAborted
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.preflight import preflight
from choreo.play.report import Outcome
from choreo.show.custody import Custody, CustodyClock, CustodyPlayer, Holder
from choreo.show.messages import StopCause

WAVE = REPO / "motions" / "arm6" / "wave.yaml"  # 4.9 s
BEAT_PERIOD_S = 0.1
MAX_SILENCE_S = 0.4


class Conductor:
    """Beats every BEAT_PERIOD_S of virtual time until ``silent_from_s`` (then frozen): its
    beats are delivered while the player waits, as Zenoh's thread would deliver them."""

    def __init__(self, clock: VirtualClock, custody: Custody, silent_from_s: float):
        self.clock, self.custody, self.silent_from_s = clock, custody, silent_from_s
        self.next_beat_s, self.seq = clock.now(), 0
        self.beats_s: list[float] = []

    def block(self, timeout_s: float) -> bool:
        """The wait of a CustodyClock, in virtual time."""
        end_s = self.clock.now() + timeout_s
        while self.next_beat_s <= min(end_s, self.silent_from_s):
            self.clock.sleep_until(self.next_beat_s)
            self.custody.beat(self.seq)
            self.beats_s.append(self.next_beat_s)
            self.seq += 1
            self.next_beat_s += BEAT_PERIOD_S
        self.clock.sleep_until(end_s)
        return self.custody.stopped.is_set()


def play_held(silent_from_s: float):
    """The wave, held by a conductor that falls silent at ``silent_from_s`` (virtual time)."""
    rig = Rig(WAVE)
    custody = Custody(Holder("show-1", "t" * 32), rig.clock, MAX_SILENCE_S)
    custody.conductor_alive = True
    conductor = Conductor(rig.clock, custody, silent_from_s)
    start, limits = preflight(rig.bus, rig.robot)
    performance = prepare(compile_motion(rig.motion), start)
    clock = CustodyClock(rig.clock, custody, conductor.block)
    player = CustodyPlayer(custody, rig.bus, rig.robot, clock, limits)
    report = player.play(performance.ticks, start, start_at_s=rig.clock.now() + 0.5)
    return rig, custody, conductor, report


def test_a_silent_conductor_stops_the_servos_at_the_silence_bound_and_nothing_moves_after():
    rig, custody, conductor, report = play_held(silent_from_s=2.05)
    assert report.outcome is Outcome.ABORTED
    assert report.reason == "lost the conductor (no heartbeat for 400 ms)"
    assert custody.request is not None and custody.request.cause is StopCause.SILENCE
    last_beat_s = conductor.beats_s[-1]
    assert last_beat_s == pytest.approx(2.0)
    assert custody.request.at_s == pytest.approx(last_beat_s + MAX_SILENCE_S)  # not later
    assert 0 < report.ticks_played < report.ticks_total  # stopped mid-part
    stops = rig.packets(Command.MOVE_STOP)
    assert stops, "no MOVE_STOP on the wire"
    stop_s = stops[-1].time_s
    assert custody.request.at_s <= stop_s
    assert custody.servos_stopped_s is not None and custody.servos_stopped_s >= custody.request.at_s
    moves = rig.emulator.log.moves
    assert any(m.time_s < custody.request.at_s for m in moves)  # it was dancing
    assert [m for m in moves if m.time_s > stop_s] == []  # and nothing moved after


def test_a_beating_conductor_keeps_the_part_going_to_its_end():
    rig, custody, _, report = play_held(silent_from_s=1e9)
    assert report.outcome is Outcome.COMPLETED
    assert custody.request is None and custody.servos_stopped_s is None
    assert rig.packets(Command.MOVE_STOP) == []


def test_the_first_stop_is_kept_with_its_cause():
    clock = VirtualClock()
    custody = Custody(Holder("show-1", "t" * 32), clock, MAX_SILENCE_S)
    clock.advance(0.1)
    custody.stop(StopCause.CONDUCTOR_LOST, "lost the conductor (its liveliness token vanished)")
    clock.advance(1.0)
    assert custody.check_silence()  # stopped already: the silence does not replace the cause
    custody.stop(StopCause.STOP_MESSAGE, "stopped by the conductor: test")
    assert custody.request is not None
    assert (custody.request.cause, custody.request.at_s) == (StopCause.CONDUCTOR_LOST, 0.1)


def test_a_conductor_is_live_while_its_token_is_there_and_it_beats():
    clock = VirtualClock()
    custody = Custody(Holder("show-1", "t" * 32), clock, MAX_SILENCE_S)
    assert not custody.live()  # no token heard yet
    custody.conductor_alive = True
    assert custody.live()
    clock.advance(0.3)
    custody.beat(5)
    clock.advance(0.3)
    custody.beat(5)  # a replay does not count
    custody.beat(4)
    assert custody.live() and custody.silence_s() == pytest.approx(0.3)
    clock.advance(0.1)
    assert not custody.live() and not custody.stopped.is_set()  # stopped only when looked at
    assert custody.check_silence()


def test_a_stopped_custody_wakes_its_sleeper_with_the_reason():
    custody = Custody(Holder("show-1", "t" * 32), RealClock(), 3600)
    clock = CustodyClock(RealClock(), custody)
    deadline = clock.now() + 0.01
    clock.sleep_until(deadline)
    assert clock.now() >= deadline
    threading.Timer(
        0.01, custody.stop, (StopCause.STOP_MESSAGE, "stopped by the conductor")
    ).start()
    with pytest.raises(PlaybackAborted, match="stopped by the conductor"):
        clock.sleep_until(clock.now() + 3600)  # at once: the test would hang otherwise
