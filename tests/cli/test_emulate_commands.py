"""The commands on each emulated board as a user runs them: scan, servo info, play of three
robots' motions, a refused command, and Ctrl-C on a board served on a pty (real clock: the test
checks what reaches the wire and in which order, never how soon)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys

import pytest
from cli_helpers import play_here_then_signal
from emulated import home_specs, play_then_signal, served_on_a_pty

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
    port = f"sim://?board={board}&ids={servos}&model={model}&clock=virtual"
    assert main(["play", motion, "--port", port, "--speed", "2", "--stretch", "--loop", "1"]) == 0
    captured = capsys.readouterr()
    assert "completed" in captured.out and "path err" in captured.out
    assert f"transport {TRANSPORT[board]}: no staged start" in captured.out
    assert "motor mode" in captured.err  # preflight says what it could not check


@pytest.fixture
def board_on_a_pty(board, tmp_path):
    emulator = BOARDS[board](home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyBOARD") as link:
        yield board, emulator, f"{board}://{link}"


MOVES = (Command.MOVE_TIME_WRITE, Command.MOVE_TIME_WAIT_WRITE, Command.MOVE_START)


# each board once, each stop signal once (test_play_commands sends both to the raw bus; the CLI
# treats them alike): Ctrl-C to a `choreo play` process of its own, SIGHUP to this process,
# playing here (a process costs 0.8 s of CPU to start; the command's own handler must take it).
# The LOBOT's holds are checked against where the servos stand once the process is gone: a play
# here returns before the emulator, on the real clock, has them back where they were read.
@pytest.mark.parametrize(
    "board, signum, here", [("rrc", signal.SIGHUP, True), ("lobot", signal.SIGINT, False)]
)
def test_a_signal_puts_the_boards_stop_on_the_wire_and_nothing_moves_after_it(
    board_on_a_pty, signum, here, monkeypatch
):
    """Order and content, not time (benchmarks/bench_stop.py prints how soon the stop comes)."""
    board, emulator, port = board_on_a_pty

    def playing(log: list) -> bool:  # the approach and two ticks
        return sum(p.packet.command == Command.MOVE_TIME_WRITE for p in log) >= 18

    if here:
        returncode, stderr, after = play_here_then_signal(
            monkeypatch, emulator, port, signum, playing
        )
    else:
        returncode, stderr, after = play_then_signal(emulator, port, signum, playing)
    assert returncode == 130, stderr
    assert "Traceback" not in stderr
    commands = [(p.packet.command, p.packet.servo_id) for p in after]
    if board == "rrc":  # one stop frame: MOVE_STOP to each servo in turn
        stop = [(Command.MOVE_STOP, i) for i in range(1, 7)]
    else:  # no MOVE_STOP: the positions of all six are read, then each is told to stay there
        reads = [(Command.POS_READ, i) for i in range(1, 7)]
        holds = [(Command.MOVE_TIME_WRITE, i) for i in range(1, 7)]
        stop = reads + holds
    # (a tick already on its way, or a health read, may come between the signal and the stop)
    start = next((i for i in range(len(commands)) if commands[i : i + len(stop)] == stop), None)
    assert start is not None, [(c.name, i) for c, i in commands]
    if board == "lobot":  # each told to stay where it is, at once, and it stayed there
        for hold in after[start + 6 : start + 12]:
            held = decode_request(hold.packet)
            assert held["time_ms"] == 0
            position = emulator.servo(hold.packet.servo_id).position_units
            assert position == pytest.approx(held["pos_units"], abs=1)
    # the stop is the last thing that moves the servos: nothing after it starts a move
    assert not [c for c, _ in commands[start + len(stop) :] if c in MOVES]


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


def test_servo_unload_through_the_lobot_controller_unloads_and_says_it_is_not_read_back(
    monkeypatch, capsys
):
    from choreo.emulator import protocol_sim

    built = []
    build = protocol_sim.emulator_from_url
    monkeypatch.setattr(
        protocol_sim, "emulator_from_url", lambda url: built.append(build(url)) or built[-1]
    )
    port = "sim://?board=lobot&ids=1-4&clock=virtual"
    assert main(["servo", "unload", "--id", "3", "--port", port]) == 0
    assert capsys.readouterr().out == (
        "servo 3: unloaded (turns freely by hand; not read back: the LOBOT controller cannot "
        "read the load state)\n"
    )
    [emulator] = built
    emulator.clock.advance(0.1)  # the frame crosses the 9600-baud link and the servo bus
    emulator.catch_up()
    sent = [(p.packet.servo_id, p.packet.command, p.packet.params) for p in emulator.log.packets]
    assert sent == [(3, Command.LOAD_OR_UNLOAD_WRITE, b"\x00")]  # the servos got the unload
