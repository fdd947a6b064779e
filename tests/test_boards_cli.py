"""The commands on each emulated board as a user runs them: scan, servo info, play of three
robots' motions, a refused command, and Ctrl-C on a board served on a pty (real clock)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

import pytest
from emulated import home_specs, served_on_a_pty, wait_for

from choreo.bus.protocol import Command, decode_request
from choreo.cli import main
from choreo.core.clock import RealClock
from choreo.emulator.boards import BOARDS
from choreo.robot.robot_file import load_robot

TRANSPORT = {"rrc": "RRC board", "lobot": "LOBOT controller"}


@pytest.mark.parametrize("board", BOARDS)
def test_scan_and_servo_info(board, capsys):
    port = f"sim://?board={board}&ids=1-4&clock=virtual"
    assert main(["scan", "--port", port, "--ids", "0-6"]) == 0
    out = capsys.readouterr().out
    assert "4 servo(s)" in out
    assert main(["servo", "info", "--id", "3", "--port", port]) == 0
    out = capsys.readouterr().out
    assert "500 (120.0°)" in out
    assert f"not readable through the {TRANSPORT[board]}" in out


@pytest.mark.parametrize("board", BOARDS)
def test_a_refused_command_names_the_transport(board, capsys):
    port = f"sim://?board={board}&ids=1-4&clock=virtual"
    assert main(["servo", "motor", "--id", "1", "--speed", "300", "--port", port]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"choreo: error: {port}: the {TRANSPORT[board]} cannot send")
    assert "raw LX bus" in err[0]


@pytest.mark.parametrize("board", BOARDS)
@pytest.mark.parametrize(
    "motion, servos",
    [
        ("motions/arm6/wave.yaml", "1-6"),
        ("motions/hexapod18/tripod_gait.yaml", "1-18"),
        ("motions/tonypi/bow.yaml", "1-18"),
    ],
)
def test_play_through_the_board(board, motion, servos, capsys):
    robot = load_robot({"arm6": "arm6", "hexa": "hexapod18", "tony": "tonypi"}[motion[8:12]])
    assert len(robot.joints) == int(servos.split("-")[1])
    model = robot.joints[0].servo_model  # preflight checks the supply against it
    port = f"sim://?board={board}&ids={servos}&model={model}"
    assert main(["play", motion, "--port", port, "--speed", "2", "--stretch", "--loop", "1"]) == 0
    captured = capsys.readouterr()
    assert "completed" in captured.out and "path err" in captured.out
    assert f"transport {TRANSPORT[board]}: no staged start" in captured.out
    assert "motor mode" in captured.err  # preflight says what it could not check


@pytest.fixture(params=list(BOARDS))
def board_on_a_pty(request, tmp_path):
    board = request.param
    emulator = BOARDS[board](home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyBOARD") as link:
        yield board, emulator, f"{board}://{link}"


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGHUP])
def test_sigint_puts_the_boards_stop_on_the_wire_within_50_ms(board_on_a_pty, signum):
    board, emulator, port = board_on_a_pty
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "play", "motions/arm6/dance.yaml", "--port", port]
        + ["--timeout-ms", "500", "--health-timeout-ms", "100"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:

        def playing():
            if process.poll() is not None:
                raise AssertionError(f"choreo play exited early: {process.communicate()[1]}")
            moves = [p for p in list(emulator.log.packets) if p.packet.command == 1]
            return len(moves) >= 60  # the approach and some ticks

        wait_for(playing, "the motion to be playing")
        pressed_s = time.monotonic()
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr
    after = [p for p in list(emulator.log.packets) if p.time_s > pressed_s]
    if board == "rrc":  # one stop frame: MOVE_STOP to each servo in turn
        stops = [p for p in after if p.packet.command == Command.MOVE_STOP]
        assert [p.packet.servo_id for p in stops] == [1, 2, 3, 4, 5, 6]
        assert stops[0].time_s - pressed_s < 0.050
    else:  # no MOVE_STOP: the positions of all six are read, then each is told to stay there
        commands = [(p.packet.command, p.packet.servo_id) for p in after]
        reads = [(Command.POS_READ, i) for i in range(1, 7)]
        holds = [(Command.MOVE_TIME_WRITE, i) for i in range(1, 7)]
        # (a health read, six POS_READs too, may come between the signal and the stop)
        stop = reads + holds
        start = next((i for i in range(len(commands)) if commands[i : i + 12] == stop), None)
        assert start is not None, [(c.name, i) for c, i in commands]
        assert after[start].time_s - pressed_s < 0.050
        hold = decode_request(after[start + 6].packet)
        assert hold["time_ms"] == 0


@pytest.mark.parametrize("board", BOARDS)
def test_the_emulate_command_serves_a_board_that_its_scheme_reaches(board, tmp_path, capsys):
    link = tmp_path / "ttyBOARD"
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "emulate", "--pty", str(link), "--servos", "1-3"]
        + ["--board", board],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        ready = process.stdout.readline()
        assert ready.startswith(f"emulating servos 1-3 (LX-16A) behind the {board} board"), (
            process.stderr.read()
        )
        assert main(["scan", "--port", f"{board}://{link}", "--ids", "0-4"]) == 0
        assert "3 servo(s)" in capsys.readouterr().out
    finally:
        process.send_signal(signal.SIGINT)
        process.communicate(timeout=30)
    assert process.returncode == 130  # stopped by Ctrl-C


def test_the_dry_run_through_a_board_prints_its_move_frames(capsys):
    from choreo.bus.transports import rrc

    assert (
        main(["play", "motions/arm6/wave.yaml", "--dry-run", "--port", "rrc:///dev/nothing"]) == 0
    )
    out = capsys.readouterr().out
    assert "through the RRC board: no staging, one move frame per tick" in out
    rows = [re.match(r"\s*\d+ ms  ([0-9a-f ]+?)  tick \d+:", line) for line in out.splitlines()]
    frames = [bytes.fromhex(row[1]) for row in rows if row]
    assert len(frames) > 10
    decoded = [rrc.FrameDecoder().feed(f) for f in frames]
    assert all(len(d) == 1 and d[0].data[0] == rrc.MOVE for d in decoded)  # CRCs hold
    assert decoded[0][0].data[3] == 6  # the first tick moves every servo
