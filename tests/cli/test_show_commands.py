"""Shows end to end: `choreo perform` processes on emulated buses and one `choreo show`, all on
loopback (each performer listens on its own 127.0.0.1 port, the conductor connects to them; no
scouting), killed and interrupted mid-show. Order and content only: no timing is asserted."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest
from paths import DATA, REPO

ROOT = REPO
SHOWS = DATA / "shows"
ARM = "sim://?ids=1-6"
WAIT_S = 30.0  # the most any step may take before the test fails (never reached when working)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Process:
    """A choreo command in the background, its stderr collected line by line."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "choreo", *args],
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: list[str] = []
        self._out: list[str] = []
        self._readers = [
            threading.Thread(target=self._read, args=(self.proc.stderr, self.lines), daemon=True),
            threading.Thread(target=self._read, args=(self.proc.stdout, self._out), daemon=True),
        ]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(stream, into: list[str]) -> None:
        for line in stream:
            into.append(line.rstrip("\n"))

    def wait_for(self, text: str, stream: str = "stderr") -> str:
        lines = self.lines if stream == "stderr" else self._out
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            found = [line for line in lines if text in line]
            if found:
                return found[0]
            if self.proc.poll() is not None and not any(r.is_alive() for r in self._readers):
                break
            time.sleep(0.02)
        raise AssertionError(f"{text!r} never came; got:\n" + "\n".join(lines + self._out))

    def finish(self) -> tuple[int, str]:
        code = self.proc.wait(timeout=WAIT_S)
        for reader in self._readers:
            reader.join(timeout=WAIT_S)
        return code, "\n".join(self.lines)

    @property
    def stdout(self) -> str:
        return "\n".join(self._out)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=WAIT_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()


@pytest.fixture
def performers():
    """Start performers by name (each on its own emulated bus and port); all stopped after."""
    started: dict[str, tuple[Process, int]] = {}

    def start(names: dict[str, str]) -> list[str]:
        for name, port in names.items():
            listen = free_port()
            process = Process(
                "perform", "--name", name, "--port", port, "--listen", f"tcp/127.0.0.1:{listen}"
            )
            started[name] = (process, listen)
        for process, _ in started.values():
            process.wait_for("waiting for a show", stream="stdout")
        return [f"tcp/127.0.0.1:{listen}" for _, listen in started.values()]

    start.started = started  # type: ignore[attr-defined]
    yield start
    for process, _ in started.values():
        process.stop()


def conductor(show: str, endpoints: list[str], *extra: str) -> Process:
    connects = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    return Process("show", str(SHOWS / show), "--no-audio", *connects, *extra)


def test_a_show_of_three_performers_runs_and_reports(performers, tmp_path):
    endpoints = performers({"one": ARM, "two": ARM, "three": ARM})
    report_path = tmp_path / "show.json"
    show = conductor("trio.yaml", endpoints, "--report", str(report_path))
    code, err = show.finish()
    assert code == 0, err
    report = json.loads(report_path.read_text())
    assert [p["name"] for p in report["performers"]] == ["one", "two", "three"]
    for part in report["performers"]:
        assert (part["outcome"], part["robot"]) == ("completed", "arm6")
        assert part["ticks_played"] == part["ticks_total"] > 0
        assert part["approach_start_s"] < part["first_start_s"]
        assert part["clock_offset_error_ms"] >= 0
        assert part["stop_s"] is None  # ran to its end: no MOVE_STOP
    three = report["performers"][2]
    assert three["offset_s"] == pytest.approx(60 / 112)  # one beat at 112 BPM
    assert report["first_start_spread_ms"] is not None
    assert "first START spread across performers" in show.stdout
    for process, _ in performers.started.values():
        process.wait_for("part completed")


def test_a_missing_performer_is_named(performers):
    endpoints = performers({"here": ARM})
    code, err = conductor("ghost.yaml", endpoints, "--wait", "1").finish()
    assert code == 1
    assert "1 performer(s) did not appear within 1 s: ghost" in err
    assert "choreo perform --name ghost" in err


def test_a_failed_preflight_is_listed_and_the_show_refuses_to_start(performers):
    # right's bus lacks the gripper (ID 6): its preflight fails; left's passes but must not play
    endpoints = performers({"left": ARM, "right": "sim://?ids=1-5"})
    code, err = conductor("duo.yaml", endpoints).finish()
    assert code == 1
    assert "refusing to start the show:" in err
    assert "right (arm6): 1 servo(s) did not answer: gripper (ID 6)" in err
    left = performers.started["left"][0]
    left.wait_for("part dropped, servos stopped")
    assert not any("playing" in line for line in left.lines)


def test_killing_the_conductor_stops_every_performer(performers):
    endpoints = performers({"left": ARM, "right": ARM})
    show = conductor("wave_duo.yaml", endpoints)
    for process, _ in performers.started.values():
        process.wait_for("playing")
    show.proc.kill()
    for name, (process, _) in performers.started.items():
        process.wait_for(f"{name}: part stopped: lost the conductor")
        summary = process.wait_for("emulated bus:")
        assert summary == (
            f"{name}: emulated bus: MOVE_STOP on the wire; "
            "0 move(s) started after it: every servo stopped"
        )
    show.finish()


def test_killing_a_performer_is_reported_and_stops_the_others(performers, tmp_path):
    endpoints = performers({"left": ARM, "right": ARM})
    report_path = tmp_path / "show.json"
    show = conductor("wave_duo.yaml", endpoints, "--report", str(report_path))
    show.wait_for("every performer took the start")  # then right dies: lost, not silent
    right = performers.started["right"][0]
    right.wait_for("playing")
    performers.started["left"][0].wait_for("playing")
    right.proc.kill()
    code, err = show.finish()
    assert code == 1, err
    assert "right: lost (its liveliness token vanished)" in err
    parts = {p["name"]: p for p in json.loads(report_path.read_text())["performers"]}
    assert parts["right"]["outcome"] == "lost"
    assert parts["left"]["outcome"] == "stopped"
    assert parts["left"]["reason"] == (
        "stopped by the conductor: right aborted or was lost (on_abort: stop)"
    )
    assert parts["left"]["stop_s"] is not None  # its MOVE_STOP on the wire
    performers.started["left"][0].wait_for("every servo stopped")


def test_ctrl_c_at_the_conductor_stops_every_performer(performers, tmp_path):
    endpoints = performers({"left": ARM, "right": ARM})
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
        assert part["stop_s"] is not None
    for process, _ in performers.started.values():
        process.wait_for("every servo stopped")


def test_with_on_abort_continue_the_others_finish_when_one_is_lost(performers, tmp_path):
    endpoints = performers({"left": ARM, "right": ARM})
    report_path = tmp_path / "show.json"
    show = conductor("duo_continue.yaml", endpoints, "--report", str(report_path))
    right = performers.started["right"][0]
    right.wait_for("playing")
    right.proc.kill()
    code, err = show.finish()
    assert code == 1, err
    assert "right: lost (its liveliness token vanished)" in err
    parts = {p["name"]: p for p in json.loads(report_path.read_text())["performers"]}
    assert (parts["right"]["outcome"], parts["left"]["outcome"]) == ("lost", "completed")
    assert parts["left"]["ticks_played"] == parts["left"]["ticks_total"]
    assert json.loads(report_path.read_text())["stop_sent_s"] is None


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
