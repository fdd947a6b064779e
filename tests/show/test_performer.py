"""A performer takes stage, start and stop only from the conductor that holds its part: driven
by hand from another Zenoh session on loopback, as an impostor would. Order and content only."""

from __future__ import annotations

import os
import time

import pytest
from show_helpers import PATIENT_SILENCE_S, Caller, Stage, eventually

from choreo.core.clock import RealClock
from choreo.play.realtime import how_to_allow
from choreo.show.custody import DEFAULT_MAX_SILENCE_S, Custody, Holder
from choreo.show.messages import Go, encode
from choreo.show.network import Network


@pytest.fixture
def stage(request):
    """The performer: patient with a silent conductor (a loaded machine's heartbeats came
    > 400 ms apart and a part playing to its end was dropped), but in the tests of the silence
    bound, which ask for the default (``SILENCE_BOUND``)."""
    stage = Stage(max_silence_s=getattr(request, "param", PATIENT_SILENCE_S))
    yield stage
    stage.close()


SILENCE_BOUND = pytest.mark.parametrize("stage", [DEFAULT_MAX_SILENCE_S], indirect=True)


@pytest.fixture
def session(stage):
    """Callers on one session connected to the performer; their heartbeats end with the test."""
    network = Network(connect=[stage.endpoint])
    eventually(lambda: network.alive(network.realm.performer("tony")), "the performer is seen")
    callers: list[Caller] = []

    def caller(show_id: str = "show-1", ticket: str | None = None) -> Caller:
        callers.append(Caller(network, show_id, ticket))
        return callers[-1]

    yield caller
    for one in callers:
        one.fall_silent()
    network.close()


def test_a_part_from_a_session_with_no_conductor_is_refused(stage, session):
    impostor = session()  # no liveliness token, no heartbeat
    ready = impostor.stage()
    assert ready is not None and ready.problems == (
        "no conductor holds show show-1 (no liveliness token): a part is taken only from a "
        "running `choreo show`",
    )
    assert impostor.info().state == "idle"
    assert impostor.go().problem == "no part is staged"


def test_a_performer_held_by_one_show_is_busy_for_another(stage, session):
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    other = session("show-2")
    other.hold()
    assert other.stage().problems == ("busy with show show-1",)
    assert conductor.info().show_id == "show-1"
    conductor.fall_silent()


def test_a_start_for_another_show_or_without_the_ticket_is_refused(stage, session):
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    assert (
        conductor.go(show_id="show-2").problem == "the staged part is show show-1's, not show-2's"
    )
    assert conductor.go(ticket="0" * 32).problem == (
        "the start did not come from the conductor that staged show show-1"
    )
    assert conductor.info().state == "staged"  # refused starts leave the part as it was
    assert conductor.go().ok  # the conductor's own start is taken
    eventually(lambda: stage.heard("part completed"), "the part plays to its end")


def test_a_performer_refused_real_time_priority_plays_its_part_and_says_how_to_allow_it(
    stage, session, monkeypatch
):
    """As an unprivileged user runs it (the tests run as root, who is always permitted)."""

    def not_permitted(*_):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "sched_setscheduler", not_permitted)
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok and conductor.go().ok
    eventually(lambda: stage.heard("part completed"), "the part plays to its end")
    assert stage.heard(f"normal priority: a busy computer can make STARTs late; {how_to_allow()}")


def test_a_stop_not_signed_with_the_ticket_is_ignored_and_the_conductor_s_is_obeyed(stage, session):
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    conductor.stop("anyone", signed_with="f" * 32)  # a stranger who overheard the show id
    eventually(lambda: stage.heard("ignored a stop for show show-1"), "the forged stop is seen")
    assert conductor.info().state == "staged"
    conductor.stop("the real one")
    eventually(lambda: stage.heard("part dropped, servos stopped"), "the part is dropped")
    assert stage.heard("stopped by the conductor: the real one: part dropped")
    eventually(lambda: conductor.info().state == "idle", "the performer is free again")


@SILENCE_BOUND
def test_a_silent_conductor_loses_its_part_and_its_start_is_refused(stage, session):
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    conductor.fall_silent()  # frozen: its token stays, its heartbeat stops
    eventually(lambda: stage.heard("part dropped"), "the part is dropped")
    assert stage.heard("lost the conductor (no heartbeat for ")
    eventually(lambda: conductor.info().state == "idle", "the performer is free again")
    assert conductor.go().problem == "no part is staged"


def test_a_start_right_after_the_staging_is_taken_before_the_token_s_news_arrives(
    stage, session, monkeypatch
):
    """The staging found the conductor's token; the watch's own report of it may come after the
    start (on a busy machine it did): that start is taken, and a vanished token still stops."""
    reports: list = []

    def watch_reporting_nothing_yet(key, on_change):
        reports.append(on_change)
        return lambda: None  # the cancel

    monkeypatch.setattr(stage.network, "watch", watch_reporting_nothing_yet)
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    answer = conductor.go()
    assert answer is not None and answer.ok, answer
    (vanished,) = reports  # then the token goes: the part stops as when the watch reports it
    vanished("show-1", False)
    eventually(lambda: stage.heard("lost the conductor (its liveliness token vanished)"), "stop")


def test_a_start_while_the_conductor_is_not_live_is_refused(stage):
    """Between a conductor going silent and its part being dropped, its start is refused too."""
    performer = stage.performer
    custody = Custody(Holder("show-1", "t" * 32), RealClock(), 0.4)
    performer.custody = custody
    assert performer._refusal_of(encode(Go("show-1", 0.0, "t" * 32))) == (
        "no live conductor holds show show-1"  # no liveliness token heard
    )
    custody.conductor_alive, custody.last_beat_s = True, time.monotonic() - 1.0
    assert performer._refusal_of(encode(Go("show-1", 0.0, "t" * 32))) == (
        "no live conductor holds show show-1"  # silent
    )
    performer.custody = None


@SILENCE_BOUND
def test_forged_heartbeats_do_not_keep_a_part_alive(stage, session):
    conductor = session("show-1")
    conductor.hold()
    assert conductor.stage().ok
    conductor.fall_silent()
    forger = session("show-1", ticket="e" * 32)  # same show id, not its ticket
    forger.hold()  # beats, signed with the wrong ticket
    eventually(lambda: stage.heard("part dropped"), "the part is dropped")
    assert stage.heard("lost the conductor (no heartbeat for ")
