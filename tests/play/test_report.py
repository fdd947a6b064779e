"""``choreo play --report FILE.json``: the JSON read back; a bad path refused before playing."""

from __future__ import annotations

import dataclasses
import json
import signal
from pathlib import Path

import pytest
from cli_helpers import play_here_then_signal

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.cli import main
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, connection
from choreo.emulator.trace import start_skew_ms
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.player import Player
from choreo.play.preflight import preflight
from choreo.play.report import (
    Outcome,
    PlayReport,
    report_document,
    transport_of,
    write_report,
)


def test_play_writes_a_report_that_reads_back(tmp_path, capsys, virtual_built_in_emulator):
    path = tmp_path / "wave.json"
    path.write_text("an older report\n")  # replaced whole
    assert (
        main(["play", "motions/arm6/wave.yaml", "--speed", "2", "--stretch", "--report", str(path)])
        == 0
    )
    report = json.loads(path.read_text())
    assert report["format"] == "choreo-play-report" and report["version"] == 1
    assert report["outcome"] == "completed" and report["robot"] == "arm6"
    assert report["transport"] == {
        "kind": "sim",
        "name": "raw LX bus",
        "port": "sim://",
        "emulated": True,
    }
    ticks = report["ticks"]
    assert ticks["played"] == ticks["total"] > 10
    assert report["start_lateness_ms"]["starts"] >= 1
    assert 0 <= report["start_lateness_ms"]["p50"] <= report["start_lateness_ms"]["max"]
    assert report["start_skew_ms"] == {"max": 0.0, "measured": True}  # one broadcast START
    assert report["bus"]["bytes_sent"] > 0 and 0 < report["bus"]["use_fraction"] < 1
    assert [s["id"] for s in report["servos"]] == [1, 2, 3, 4, 5, 6]
    assert all(s["path_error_deg"] is not None for s in report["servos"])
    assert report["path_error_deg_max"] == max(s["path_error_deg"] for s in report["servos"])
    assert sum(s["reads"] for s in report["servos"]) > 0
    assert "completed" in capsys.readouterr().out  # the printed report is still there
    assert [p.name for p in tmp_path.iterdir()] == ["wave.json"]  # no temporary left behind


def test_an_interrupted_play_on_a_serial_port_reports_it(arm_on_a_pty, tmp_path, monkeypatch):
    # A real port (a pty): kind "serial", nothing to measure the path error with. Played here,
    # stopped by SIGHUP (as Ctrl-C: the signals themselves are tested in tests/cli/)
    emulator, link = arm_on_a_pty
    path = tmp_path / "r.json"

    def playing(packets: list) -> bool:
        return sum(p.packet.command == Command.MOVE_START for p in packets) >= 3

    code, stderr, _ = play_here_then_signal(
        monkeypatch, emulator, str(link), signal.SIGHUP, playing, "--report", str(path)
    )
    assert code == 130, stderr
    report = json.loads(path.read_text())
    assert report["outcome"] == "interrupted"
    assert report["transport"] == {
        "kind": "serial",
        "name": "raw LX bus",
        "port": str(link),
        "emulated": False,
    }
    assert 3 <= report["ticks"]["played"] < report["ticks"]["total"]
    assert report["start_skew_ms"] == {"max": 0.0, "measured": False}
    assert report["path_error_deg_max"] is None


def test_a_report_in_a_missing_folder_is_refused_before_anything_plays(tmp_path, capsys):
    path = tmp_path / "no-such-folder" / "r.json"
    assert main(["play", "motions/arm6/wave.yaml", "--report", str(path)]) == 1
    captured = capsys.readouterr()
    assert f"the folder {path.parent} does not exist" in captured.err
    assert "built-in emulated bus" not in captured.err and captured.out == ""
    assert main(["play", "motions/arm6/wave.yaml", "--report", str(tmp_path)]) == 1
    assert "is a folder" in capsys.readouterr().err


def test_a_report_in_a_folder_it_cannot_write_is_refused_before_anything_plays(
    tmp_path, monkeypatch, capsys
):
    # (Tests may run as root, for whom every folder is writable: the permission is faked.)
    monkeypatch.setattr("choreo.core.atomic.os.access", lambda path, mode: False)
    assert main(["play", "motions/arm6/wave.yaml", "--report", str(tmp_path / "r.json")]) == 1
    captured = capsys.readouterr()
    assert f"the folder {tmp_path} is not writable" in captured.err and captured.out == ""


def test_a_report_of_a_dry_run_is_a_usage_error(tmp_path, capsys):
    path = tmp_path / "r.json"
    assert main(["play", "motions/arm6/wave.yaml", "--dry-run", "--report", str(path)]) == 2
    assert "--dry-run plays nothing" in capsys.readouterr().err
    assert not path.exists()


def test_the_report_of_an_aborted_echoing_play_in_virtual_time(tmp_path):
    # The whole chain without the CLI: a servo vanishes mid-play on an echoing bus.
    motion = load_motion("motions/hexapod18/tripod_gait.yaml")
    robot = motion.robot
    specs = [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, robot.pose_vector("home"))
    ]
    emulator = BusEmulator(specs, clock=VirtualClock(), echo=True)
    bus = ServoBus(connection(emulator))
    start, limits = preflight(bus, robot)
    performance = prepare(compile_motion(motion), start)
    player = Player(bus, robot, emulator.clock, limits)
    ticks = performance.ticks
    cut = len(ticks) // 2
    report = player.play(ticks[:cut], start)
    emulator.servo(5).connected = False
    reached = [j.to_deg(u) for j, u in zip(robot.joints, ticks[cut - 1].targets_units)]
    aborted = player.play(ticks[cut:], reached)
    assert report.outcome is Outcome.COMPLETED and aborted.outcome is Outcome.ABORTED
    described = PlayReport.of(
        aborted,
        motion="tripod_gait.yaml",
        robot=robot.name,
        port="sim://?ids=1-18&echo=1",
        measured_start_skew_ms=start_skew_ms(emulator.log.moves),
    )
    document = report_document(described)
    path = tmp_path / "r.json"
    write_report(path, document)
    read = json.loads(path.read_text())
    assert read["outcome"] == "aborted" and "(ID 5) stopped answering" in read["reason"]
    lost = read["servos"][4]
    assert lost["id"] == 5 and lost["missed_reads"] == 3 == read["bus"]["missed_reads"]
    assert read["path_error_deg_max"] is None and lost["path_error_deg"] is None
    assert read["start_lateness_ms"]["max"] == 0.0  # virtual time is exact
    assert read["transport"]["kind"] == "sim"


@pytest.mark.parametrize(
    "port,kind",
    [
        ("/dev/ttyUSB0", "serial"),
        ("COM3", "serial"),
        ("sim://?ids=1-6", "sim"),
        ("rrc:///dev/ttyAMA0", "rrc"),
        ("lobot://hid", "lobot"),
    ],
)
def test_the_transport_is_the_ports_scheme(port, kind):
    transport = transport_of(port)
    assert (transport.kind, transport.port, transport.start_skew_ms) == (kind, port, 0.0)
    assert transport.emulated is (kind == "sim")


def test_an_unmeasured_skew_is_the_transports_own():
    # Real servos: nothing measures the skew, so the transport's figure is reported as such.
    board_play = dataclasses.replace(
        _empty_report(), port="rrc:///dev/ttyAMA0", transport="RRC board", start_skew_ms=4.4
    )
    document = report_document(board_play)
    assert document["start_skew_ms"] == {"max": 4.4, "measured": False}


def _empty_report():
    return PlayReport(Outcome.COMPLETED, "", 0, 0, 0, (), 0, 0.0, 0.0, (), 0.0)


def test_a_report_through_a_board_names_it_and_its_start_skew(tmp_path):
    """Through the emulated RRC board a tick's servos start one after another: the report names
    the board and the skew measured on the servos' wire log."""
    path = tmp_path / "rrc.json"
    port = "sim://?board=rrc&ids=1-6&clock=virtual"
    assert main(["play", "motions/arm6/wave.yaml", "--port", port, "--report", str(path)]) == 0
    report = json.loads(path.read_text())
    assert report["transport"]["name"] == "RRC board"
    assert report["transport"]["kind"] == "sim" and report["transport"]["emulated"]
    # forwarded at about 0.87 ms a servo: not 0 as with a broadcast START, at most ~4.3 ms
    # for six servos (a tick that moves fewer of them is shorter)
    assert report["start_skew_ms"]["measured"]
    assert 0.8 < report["start_skew_ms"]["max"] < 6 * 0.87 + 0.5


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="Linux's /proc")
def test_a_report_where_no_file_can_be_made_is_refused_before_anything_plays(capsys):
    assert main(["play", "motions/arm6/wave.yaml", "--report", "/proc/r.json"]) == 1
    captured = capsys.readouterr()
    assert captured.err.startswith("choreo: error: cannot write /proc/r.json: the folder /proc")
    assert "built-in emulated bus" not in captured.err and captured.out == ""
