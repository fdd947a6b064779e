"""Shows end to end: performers on emulated buses and one `choreo show`, all on loopback (each
performer listens on its own 127.0.0.1 port, the conductor connects to them; no scouting), killed
and interrupted mid-show. Each `choreo` process costs about 0.8 s of CPU to start, so a process
is used only where it is what the test is about: a conductor killed, frozen or sent Ctrl-C from
outside, a performer killed or another's pid; else the conductor runs in the test's process
(main(argv)) and the performers serve in its threads, saying what `choreo perform` prints
(perform_helpers). Order and content only: no timing is asserted."""

from __future__ import annotations

import io
import json
import os
import re
import signal
import socket
import sys
from collections.abc import Callable

import pytest
from cli_helpers import ChoreoProcess as Process
from cli_helpers import main_while, said_eventually, signal_noted
from paths import DATA
from perform_helpers import ARM, Troupe, performer_here, performer_process
from show_helpers import free_port

from choreo.show.custody import DEFAULT_MAX_SILENCE_S

SHOWS = DATA / "shows"
TIME_OF_DAY = r"\d\d:\d\d:\d\d\.\d{6}"  # as a performer says when its MOVE_STOP went


@pytest.fixture(scope="module")
def troupe():
    """The performers this file's tests share (left, right, centre); stopped after."""
    shared = Troupe()
    yield shared
    shared.stop()


@pytest.fixture
def performers(troupe, request):
    """The shared performers by name (Troupe): their endpoints, in the order asked;
    ``performers.started``: this test's, by name. A test that kills a performer, or needs
    another port or silence bound, starts one of its own (performer_process, performer_here)."""
    started = troupe.begin_test()
    failed_before = request.session.testsfailed

    def start(*names: str) -> list[str]:
        return troupe.start(started, *names)

    start.started = started  # type: ignore[attr-defined]
    yield start
    troupe.end_test(started, failed=request.session.testsfailed != failed_before)


def conductor(show: str, endpoints: list[str], *extra: str) -> Process:
    """`choreo show` in a process of its own: for the tests that kill it, freeze it or send it
    Ctrl-C from outside."""
    return Process("show", *conducting(show, endpoints, *extra))


def conducting(show: str, endpoints: list[str], *extra: str) -> list[str]:
    connects = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    return [str(SHOWS / show), "--no-audio", "--go", *connects, *extra]


def conduct(capsys, show: str, endpoints: list[str], *extra: str) -> tuple[int, str, str]:
    """`choreo show` run here (its subject is not the process): exit code, stdout, stderr."""
    from choreo.cli import main

    code = main(["show", *conducting(show, endpoints, *extra)])
    out, err = capsys.readouterr()
    return code, out, err


def conduct_while(
    monkeypatch, meanwhile: Callable[[Callable[[], str]], None], show: str, endpoints: list[str],
    *extra: str,
) -> tuple[int, str]:  # fmt: skip
    """`choreo show` run here while ``meanwhile`` runs (cli_helpers.main_while): exit code,
    stderr."""
    code, _, err = main_while(
        monkeypatch, meanwhile, ["show", *conducting(show, endpoints, *extra)]
    )
    return code, err


def test_a_show_of_three_performers_runs_and_reports(performers, tmp_path, capsys):
    endpoints = performers("left", "right", "centre")
    report_path = tmp_path / "show.json"
    code, out, err = conduct(capsys, "trio.yaml", endpoints, "--report", str(report_path))
    assert code == 0, err
    report = json.loads(report_path.read_text())
    assert [p["name"] for p in report["performers"]] == ["left", "right", "centre"]
    for part in report["performers"]:
        assert (part["outcome"], part["robot"]) == ("completed", "arm6")
        assert part["ticks_played"] == part["ticks_total"] > 0
        assert part["approach_start_s"] < part["first_start_s"]
        assert part["clock_offset_error_ms"] >= 0
        assert part["stop_s"] is None  # ran to its end: no MOVE_STOP
        assert part["first_start_late_ms"] is not None  # read when its bytes were written
    centre = report["performers"][2]
    assert centre["offset_s"] == pytest.approx(60 / 112)  # one beat at 112 BPM
    assert report["first_start_spread_ms"] is not None
    assert "first START spread across performers" in out
    for process, _ in performers.started.values():
        process.wait_for("part completed")


def test_a_missing_performer_is_named(performers, capsys):
    endpoints = performers("left")
    code, _, err = conduct(capsys, "ghost.yaml", endpoints, "--wait", "1")
    assert code == 1
    assert "1 performer(s) did not appear within 1 s: ghost" in err
    assert "choreo perform --name ghost" in err


def test_a_failed_preflight_is_listed_and_the_show_refuses_to_start(performers, capsys):
    # right's bus lacks the gripper (ID 6): its preflight fails; left's passes but must not play
    right, right_endpoint = performer_here("right", port="sim://?ids=1-5")
    try:
        code, _, err = conduct(capsys, "duo.yaml", [*performers("left"), right_endpoint])
    finally:
        right.stop()
    assert code == 1
    assert "refusing to start the show:" in err
    assert "right (arm6): 1 servo(s) did not answer: gripper (ID 6)" in err
    left = performers.started["left"][0]
    left.wait_for("part dropped, servos stopped")
    assert not any("playing" in line for line in left.lines)


def test_killing_the_conductor_stops_every_performer(performers):
    endpoints = performers("left", "right")
    show = conductor("wave_duo.yaml", endpoints)
    for process, _ in performers.started.values():
        process.wait_for("playing")
    show.proc.kill()
    for name, (process, _) in performers.started.items():
        process.wait_for(f"{name}: part stopped: lost the conductor")
        stopped = process.wait_for("servos stopped")
        assert re.fullmatch(
            rf"{name}: servos stopped \(conductor lost\): MOVE_STOP written at {TIME_OF_DAY}, "
            r"\d+ ms after the conductor's last heartbeat",
            stopped,
        )
        summary = process.wait_for("emulated bus:")
        assert re.fullmatch(
            rf"{name}: emulated bus: MOVE_STOP on the wire at {TIME_OF_DAY}; "
            "0 move\\(s\\) started after it: every servo stopped",
            summary,
        )
    show.finish()


def test_killing_a_performer_is_reported_and_stops_the_others(performers, tmp_path, monkeypatch):
    right, right_endpoint = performer_process("right")  # its own: it is killed
    report_path = tmp_path / "show.json"
    endpoints = [*performers("left"), right_endpoint]

    def kill_right(said: Callable[[], str]) -> None:
        said_eventually(said, "every performer took the start")  # then right dies: lost
        right.wait_for("playing")
        performers.started["left"][0].wait_for("playing")
        right.proc.kill()

    try:
        code, err = conduct_while(
            monkeypatch, kill_right, "wave_duo.yaml", endpoints, "--report", str(report_path)
        )
    finally:
        right.stop()
    assert code == 1, err
    assert "right: lost (its liveliness token vanished)" in err
    parts = {p["name"]: p for p in json.loads(report_path.read_text())["performers"]}
    assert parts["right"]["outcome"] == "lost"
    assert parts["left"]["outcome"] == "stopped"
    assert parts["left"]["reason"] == (
        "stopped by the conductor: right aborted or was lost (on_abort: stop)"
    )
    assert parts["left"]["stop_cause"] == "stop message"
    assert None not in (
        parts["left"]["stop_written_s"],
        parts["left"]["stop_s"],
    )  # sent, on the wire
    performers.started["left"][0].wait_for("every servo stopped")


def test_ctrl_c_at_the_conductor_stops_every_performer(performers, tmp_path):
    endpoints = performers("left", "right")
    report_path = tmp_path / "show.json"
    show = conductor("wave_duo.yaml", endpoints, "--report", str(report_path))
    for process, _ in performers.started.values():
        process.wait_for("playing")
    show.proc.send_signal(signal.SIGINT)
    code, err = show.finish()
    assert code == 130, err
    report = json.loads(report_path.read_text())
    assert report["stop_reason"] == "Ctrl-C at the conductor"
    for part in report["performers"]:
        assert part["outcome"] == "stopped"
        assert part["stop_cause"] == "stop message"
        assert None not in (part["stop_written_s"], part["stop_s"])
    for process, _ in performers.started.values():
        process.wait_for("every servo stopped")


def test_with_on_abort_continue_the_others_finish_when_one_is_lost(
    performers, tmp_path, monkeypatch
):
    right, right_endpoint = performer_process("right")  # its own: it is killed
    report_path = tmp_path / "show.json"
    endpoints = [*performers("left"), right_endpoint]

    def kill_right(said: Callable[[], str]) -> None:
        # "playing" comes before right's answer to the start reaches the conductor: killed in
        # between, right never took the start (a busy machine did that)
        said_eventually(said, "every performer took the start")
        right.wait_for("playing")
        right.proc.kill()

    try:
        code, err = conduct_while(
            monkeypatch, kill_right, "duo_continue.yaml", endpoints, "--report", str(report_path)
        )
    finally:
        right.stop()
    assert code == 1, err
    assert "right: lost (its liveliness token vanished)" in err
    parts = {p["name"]: p for p in json.loads(report_path.read_text())["performers"]}
    assert (parts["right"]["outcome"], parts["left"]["outcome"]) == ("lost", "completed")
    assert parts["left"]["ticks_played"] == parts["left"]["ticks_total"]
    assert parts["left"]["clock_drift_ms"] is not None  # its clock measured again during the 5 s
    assert json.loads(report_path.read_text())["stop_sent_s"] is None
    performers.started["left"][0].wait_for("part completed")


@pytest.mark.parametrize(
    "argv",
    [
        ["show", str(SHOWS / "trio.yaml"), "--no-audio", "--connect", "bogus"],
        ["perform", "--port", ARM, "--listen", "bogus"],
    ],
)
def test_an_endpoint_that_is_not_one_is_refused_before_zenoh_sees_it(argv, capsys):
    from choreo.cli import main

    flag = argv[-2]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        f"choreo: error: {flag} 'bogus' is not a Zenoh endpoint: write PROTOCOL/HOST:PORT "
        "(PROTOCOL one of tcp, udp, tls, quic, ws; PORT 0-65535) or unixsock-stream/PATH, "
        "e.g. tcp/192.168.1.5:7447\n"
    )


def test_two_performers_of_one_name_are_refused_naming_both(performers, tmp_path, capsys):
    solo = tmp_path / "solo.yaml"
    solo.write_text(f"performers:\n  - {{name: left, motion: {SHOWS / 'nod.yaml'}}}\n")
    (one,) = performers("left")
    first = performers.started["left"][0]
    second, two = performer_process("left")
    try:
        code, _, err = conduct(capsys, str(solo), [one, two])
        assert code == 1, err
        host = socket.gethostname()
        here, there = os.getpid(), second.proc.pid  # first serves in this process
        assert (
            f"2 performers are named left, on {host} (pid {here}, on {ARM}) and "
            f"{host} (pid {there}, on {ARM}): give each its own --name"
        ) in err or (
            f"2 performers are named left, on {host} (pid {there}, on {ARM}) and "
            f"{host} (pid {here}, on {ARM}): give each its own --name"
        ) in err
        assert not any("staged" in line for line in first.lines + second.lines)
        # on loopback only: no warning about the network (since it started)
        assert not any("warning" in line for line in second.every_line)
    finally:
        second.stop()


def test_a_performer_another_show_holds_is_refused_and_its_show_goes_on(
    performers, capsys, monkeypatch
):
    from choreo.cli import main

    endpoints = performers("left", "right")
    connects = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    # the first conductor holds both, armed and waiting for its GO: then a second show is tried
    second = EnterWhenRead(lambda: conduct(capsys, "duo.yaml", endpoints))
    monkeypatch.setattr(sys, "stdin", second)
    first_code = main(["show", str(SHOWS / "duo.yaml"), "--no-audio", *connects])
    first_err = capsys.readouterr().err
    assert second.seen_before_enter is not None  # the first asked for its GO
    code, _, err = second.seen_before_enter
    assert code == 1, err
    assert "refusing to start the show:" in err
    for name in ("left", "right"):
        assert re.search(rf"{name} on \S+ is busy with show duo-[0-9a-f]{{8}} \(another", err), err
    assert first_code == 0, first_err  # the first show was not disturbed


def test_a_frozen_conductor_stops_every_performer_within_the_silence_bound():
    # performers of their own, with the default silence bound: the one under test
    default_ms = DEFAULT_MAX_SILENCE_S * 1000
    strict = {name: performer_here(name, silence_ms=default_ms) for name in ("left", "right")}
    try:
        show = conductor("wave_duo.yaml", [endpoint for _, endpoint in strict.values()])
        for process, _ in strict.values():
            process.wait_for("playing")
        show.proc.send_signal(signal.SIGSTOP)  # its liveliness token stays: its heartbeat stops
        try:
            for name, (process, _) in strict.items():
                line = process.wait_for("part stopped: lost the conductor")
                assert line.startswith(
                    f"{name}: part stopped: lost the conductor (no heartbeat for "
                )
                assert process.wait_for("servos stopped").startswith(
                    f"{name}: servos stopped (silence): MOVE_STOP written at "
                )
                assert process.wait_for("emulated bus:").endswith("every servo stopped")
        finally:
            show.proc.send_signal(signal.SIGCONT)
            show.proc.kill()
            show.finish()
    finally:
        for process, _ in strict.values():
            process.stop()


def test_sigterm_at_the_conductor_is_ctrl_c(performers, tmp_path, monkeypatch):
    """SIGTERM sent to this process while the conductor runs here (Ctrl-C at a conductor in a
    process of its own is the test above): the conductor's own handler must take it, else
    the one set here only notes it and the show plays to its end."""
    endpoints = performers("left", "right")
    report_path = tmp_path / "show.json"

    def terminate(said: Callable[[], str]) -> None:
        for process, _ in performers.started.values():
            process.wait_for("playing")
        os.kill(os.getpid(), signal.SIGTERM)

    with signal_noted(signal.SIGTERM) as unhandled:
        code, err = conduct_while(
            monkeypatch, terminate, "wave_duo.yaml", endpoints, "--report", str(report_path)
        )
    assert unhandled == []
    assert code == 130, err
    report = json.loads(report_path.read_text())
    assert report["stop_reason"] == "Ctrl-C at the conductor"
    assert [p["outcome"] for p in report["performers"]] == ["stopped", "stopped"]
    for process, _ in performers.started.values():
        process.wait_for("every servo stopped")


def test_a_performer_in_another_realm_is_not_found(performers, capsys):
    # the performer in the default realm, the conductor in lab
    code, _, err = conduct(capsys, "duo.yaml", performers("left"), "--wait", "1", "--realm", "lab")
    assert code == 1
    assert "2 performer(s) did not appear within 1 s: left, right" in err


def test_a_performer_reachable_from_the_network_without_authentication_warns(capsys, monkeypatch):
    """As `choreo perform` starts (it serves no show here: what it says first is the subject)."""
    from choreo.cli import main
    from choreo.show.performer import Performer

    monkeypatch.setattr(Performer, "serve_forever", lambda self: None)
    for listen, warned in (("0.0.0.0", True), ("127.0.0.1", False)):
        argv = ["perform", "--name", "left", "--port", ARM, "--listen"]
        assert main([*argv, f"tcp/{listen}:{free_port()}"]) == 0
        out, err = capsys.readouterr()
        assert out == f"performing as left on {ARM}: waiting for a show\n"
        warnings = [line for line in err.splitlines() if "warning" in line]
        assert len(warnings) == warned, (listen, err)
        if warned:
            assert warnings[0].startswith("choreo: warning: this session is reachable beyond this")


@pytest.mark.parametrize("port", ["sim://?ids=999", "/dev/null"])
def test_a_port_that_does_not_open_is_refused_at_start_up(port, capsys):
    from choreo.cli import main

    assert main(["perform", "--port", port, "--listen", "tcp/127.0.0.1:0"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"choreo: error: cannot open {port}: ")
    assert len(err.splitlines()) <= 2  # the error, and perhaps a hint


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["perform", "--name", "ünï"], "--name"),
        (["perform", "--realm", "a/b"], "--realm"),
        (["show", str(SHOWS / "duo.yaml"), "--realm", "ünï"], "--realm"),
    ],
)
def test_a_name_that_is_not_one_is_one_usage_line(argv, flag, capsys):
    from choreo.cli import main

    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert err[-1].endswith(f"argument {flag}: a name has only ASCII letters, digits, - and _, "
                            f"got {argv[argv.index(flag) + 1]!r}")  # fmt: skip


def test_a_zenoh_configuration_that_cannot_be_used_is_one_line(tmp_path, capsys):
    from choreo.cli import main

    bad = tmp_path / "zenoh.json5"
    bad.write_text('{mode: "bogus"}')
    argv = ["show", str(SHOWS / "duo.yaml"), "--no-audio", "--zenoh-config", str(bad)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"choreo: error: --zenoh-config {bad} is not a Zenoh configuration")
    assert err.count("\n") == 1 and ".rs:" not in err


def test_an_endpoint_the_performer_cannot_listen_on_is_one_line_naming_the_flag(capsys):
    from choreo.cli import main

    argv = ["perform", "--port", "sim://?ids=1-6", "--listen", "tls/127.0.0.1:0"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "choreo: error: --listen 'tls/127.0.0.1:0' needs this computer's TLS certificate and "
        "private key: name them in the Zenoh configuration given with --zenoh-config "
        "(transport/link/tls: listen_certificate and listen_private_key), as docs/shows.md "
        "shows\n"
    )


def test_every_problem_of_every_motion_is_listed_before_any_performer_is_sought(tmp_path, capsys):
    for name, pose in (("a.yaml", "nowhere"), ("b.yaml", "elsewhere")):
        (tmp_path / name).write_text(f"robot: arm6\nkeyframes:\n  - pose: {pose}\n")
    show = tmp_path / "show.yaml"
    show.write_text("performers:\n  - {name: a, motion: a.yaml}\n  - {name: b, motion: b.yaml}\n")
    code, _, err = conduct(capsys, str(show), [], "--wait", "30")
    assert code == 1
    lines = err.splitlines()
    assert lines[0] == "choreo: error: refusing to start the show: 2 problem(s) in its files:"
    assert lines[1].startswith(f"  {tmp_path / 'a.yaml'}:3:")
    assert lines[2].startswith(f"  {tmp_path / 'b.yaml'}:3:")
    assert "did not appear" not in err


class EnterWhenRead:
    """A keyboard whose user presses Enter once asked (input() reads a line), first noting
    what ``look`` sees then."""

    def __init__(self, look: Callable[[], object]):
        self.look, self.seen_before_enter = look, None

    def readline(self, *_) -> str:
        self.seen_before_enter = self.look()
        return "\n"


def test_the_show_is_armed_shown_and_started_on_enter(performers, capsys, monkeypatch):
    from choreo.cli import main

    endpoints = performers("left", "right")
    connects = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    said = performers.started.values()
    keyboard = EnterWhenRead(lambda: [line for p, _ in said for line in p.lines])
    monkeypatch.setattr(sys, "stdin", keyboard)
    code = main(["show", str(SHOWS / "duo.yaml"), "--no-audio", *connects])
    err = capsys.readouterr().err
    assert code == 0, err
    assert keyboard.seen_before_enter is not None  # asked for Enter
    assert not any("playing" in line for line in keyboard.seen_before_enter)
    asked = err.index("press Enter for GO")
    table = err[:asked]
    for name in ("left", "right"):
        assert re.search(rf"{name}\s.*arm6\s.*ok\s.*ms (ahead|behind)\s.*passed", table), table
    assert asked < err.index("every performer took the start")
    assert "the show begins in 1 s" in err  # the countdown's last second
    for process, _ in said:
        process.wait_for("part completed")


def test_without_enter_nothing_plays_and_every_part_is_dropped(performers, capsys, monkeypatch):
    from choreo.cli import main

    endpoints = performers("left", "right")
    connects = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))  # the input ends at once
    code = main(["show", str(SHOWS / "duo.yaml"), "--no-audio", *connects])
    err = capsys.readouterr().err
    assert code == 1
    assert (
        "choreo: error: no GO: the input ended before Enter; give --go to start without one" in err
    )
    for process, _ in performers.started.values():
        # the stop, or the conductor's token vanishing just after it: whichever comes first
        process.wait_for("part dropped, servos stopped")
        assert not any("playing" in line for line in process.lines)


def test_cues_play_one_after_another(performers, tmp_path, capsys):
    endpoints = performers("left", "right")
    report_path = tmp_path / "show.json"
    code, _, err = conduct(capsys, "cues.yaml", endpoints, "--report", str(report_path))
    assert code == 0, err
    report = json.loads(report_path.read_text())
    assert [c["show"] for c in report["cues"]] == ["cues, cue 1 (opening)", "cues, cue 2 (cue 2)"]
    assert [[p["name"] for p in c["performers"]] for c in report["cues"]] == [
        ["left"],
        ["left", "right"],
    ]
    assert all(p["outcome"] == "completed" for c in report["cues"] for p in c["performers"])
    first, second = (c["performers"][0] for c in report["cues"])
    assert first["first_start_s"] < second["approach_start_s"]  # cue 2 after cue 1 ended
    left = performers.started["left"][0]
    left.wait_for("part completed")
    assert sum("part completed" in line for line in left.lines) == 2
