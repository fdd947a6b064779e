"""Real-time priority for the player: asked for where permitted, said in one line with how to
allow it where not, recorded in the report, and given back after the play. The system calls are
replaced by fakes that record the order of events (this test must not raise its own priority)."""

from __future__ import annotations

import getpass
import os
import sys

import pytest
from play_helpers import MOTIONS, Rig

from choreo.bus.protocol import Command
from choreo.play import realtime
from choreo.play.play_options import PlayOptions
from choreo.play.report import report_document


class FakeSystem:
    """os.sched_* and mlockall of a system that permits (or not) real-time priority."""

    def __init__(self, monkeypatch, *, permitted: bool, events: list | None = None):
        self.permitted, self.events = permitted, events if events is not None else []
        self.policy, self.priority = os.SCHED_OTHER, 0
        monkeypatch.setattr(os, "sched_getscheduler", lambda pid: self.policy)
        monkeypatch.setattr(os, "sched_getparam", lambda pid: os.sched_param(self.priority))
        monkeypatch.setattr(os, "sched_setscheduler", self.set_scheduler)
        monkeypatch.setattr(realtime, "_libc", lambda: self)

    def set_scheduler(self, pid, policy, param):
        if not self.permitted and policy == os.SCHED_FIFO:
            raise PermissionError(1, "Operation not permitted")
        self.policy, self.priority = policy, param.sched_priority
        self.events.append(("policy", policy, param.sched_priority))

    def mlockall(self, flags):
        if not self.permitted:
            return -1
        self.events.append(("mlockall", flags))
        return 0

    def munlockall(self):
        self.events.append(("munlockall",))
        return 0


def test_fifo_and_locked_memory_where_permitted_and_given_back_after(monkeypatch):
    system = FakeSystem(monkeypatch, permitted=True)
    with realtime.realtime_priority() as got:
        assert (system.policy, system.priority) == (os.SCHED_FIFO, realtime.PLAY_PRIORITY)
    assert got == realtime.Scheduling("SCHED_FIFO", 50, memory_locked=True)
    assert got.describe() == "scheduling: real-time priority (SCHED_FIFO 50), memory locked"
    assert [e[0] for e in system.events] == ["policy", "mlockall", "munlockall", "policy"]
    assert system.events[-1] == ("policy", os.SCHED_OTHER, 0)  # the normal policy again


def test_where_not_permitted_one_line_says_how_to_allow_it(monkeypatch):
    system = FakeSystem(monkeypatch, permitted=False)
    with realtime.realtime_priority() as got:
        pass
    assert (got.policy, got.memory_locked, got.realtime) == ("SCHED_OTHER", False, False)
    line = got.describe()
    assert "\n" not in line and line.startswith("scheduling: normal priority (SCHED_OTHER)")
    assert "setcap cap_sys_nice" in line and "rtprio" in line and "limits.conf" in line
    # this interpreter's real file, and this user (`@name` would be a group in limits.conf)
    assert f"cap_ipc_lock+ep {os.path.realpath(sys.executable)}`" in line
    assert f"`{getpass.getuser()} - rtprio 50` and `{getpass.getuser()} - memlock" in line
    assert system.events == []  # nothing changed, nothing to give back


def test_a_user_without_a_name_is_named_for_limits_conf_by_uid(monkeypatch):
    def no_name():
        raise KeyError("getpwuid(): uid not found: 1234")

    monkeypatch.setattr(getpass, "getuser", no_name)
    monkeypatch.setattr(os, "getuid", lambda: 1234)
    assert "`1234:1234 - rtprio 50` and `1234:1234 - memlock unlimited`" in realtime.how_to_allow()


def test_the_player_plays_under_the_priority_and_the_report_records_it(monkeypatch):
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    events: list = []
    FakeSystem(monkeypatch, permitted=True, events=events)
    real_play = rig.play

    def play_recording_when(options=None, **kwargs):
        log = rig.emulator.log.packets
        monkeypatch.setattr(realtime, "_current", _noting(events, log, realtime._current))
        return real_play(options, **kwargs)

    report = play_recording_when(PlayOptions(realtime=True))
    assert report.scheduling == realtime.Scheduling("SCHED_FIFO", 50, memory_locked=True)
    # raised before the first START, given back after the last one
    starts = [p.time_s for p in rig.packets(Command.MOVE_START)]
    raised_at = next(e[1] for e in events if e[0] == "raised at")
    assert raised_at <= starts[0]
    assert events[-1][:2] == ("policy", os.SCHED_OTHER)
    document = report_document(report)
    assert document["scheduling"] == {
        "policy": "SCHED_FIFO",
        "priority": 50,
        "memory_locked": True,
        "realtime_asked": True,
    }


def _noting(events, log, current):
    def noted(locked):
        events.append(("raised at", max((p.time_s for p in log), default=0.0)))
        return current(locked)

    return noted


def test_a_virtual_clock_asks_for_no_priority(monkeypatch):
    system = FakeSystem(monkeypatch, permitted=True)
    report = Rig(f"{MOTIONS}/arm6/wave.yaml").play()
    assert report.scheduling == realtime.NOT_ASKED and system.events == []
    assert report.scheduling.describe() == (
        "scheduling: normal priority (real-time priority not asked)"
    )


@pytest.mark.parametrize("permitted", [True, False])
def test_choreo_play_says_in_one_line_which_priority_it_got(
    monkeypatch, capsys, tmp_path, permitted
):
    from choreo.cli import main

    nod = tmp_path / "nod.yaml"  # short: this plays in real time
    nod.write_text(
        "robot: arm6\nkeyframes:\n  - pose: home\n  - pose: {shoulder: 3}\n    after: 0.3\n"
    )
    FakeSystem(monkeypatch, permitted=permitted)
    assert main(["play", str(nod), "--port", "sim://?ids=1-6", "--exit", "hold"]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if "scheduling:" in line]
    expected = (
        "real-time priority (SCHED_FIFO 50)" if permitted else "normal priority (SCHED_OTHER)"
    )
    assert len(lines) == 1 and lines[0].startswith(f"scheduling: {expected}")
    assert permitted or "limits.conf" in lines[0]  # the advice on the same line
