"""`choreo emulate --pty` from a separate process, driven by a plain pyserial client; a link it
refuses before serving, with `choreo emulate` run here (main(argv): a process costs 0.2 s of CPU
to start).

This is the one emulator test on the real clock: the bridge runs in real time by design. It waits
for output with timeouts, never sleeps for a fixed time.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading

import pytest
import serial

from choreo.bus.protocol import Command as C
from choreo.bus.protocol import PacketDecoder, decode_reply, encode_request
from choreo.cli import main

STARTUP_TIMEOUT_S = 20


def start_emulator(*options: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "choreo", "emulate", *options],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},  # a hung child's stacks, on SIGABRT
    )


def ready_line(process: subprocess.Popen) -> str:
    # readline blocks until the line or EOF; the watchdog kills a hung child so the test fails.
    watchdog = threading.Timer(STARTUP_TIMEOUT_S, process.kill)
    watchdog.start()
    try:
        return process.stdout.readline()
    finally:
        watchdog.cancel()


def stop(process: subprocess.Popen, signum=signal.SIGINT) -> tuple[int, str]:
    process.send_signal(signum)
    try:
        _, stderr = process.communicate(timeout=STARTUP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGABRT)  # faulthandler prints where every thread stands
        _, stderr = process.communicate(timeout=STARTUP_TIMEOUT_S)
        hung = f"the emulator did not stop on {signum!r}; its stacks:\n{stderr}"
        raise AssertionError(hung) from None
    return process.returncode, stderr


@pytest.fixture
def link(tmp_path):
    return tmp_path / "ttyEMU"


def test_pos_read_over_the_pty_then_sigint_exits_cleanly(link, tmp_path):
    state = tmp_path / "state.json"
    process = start_emulator("--pty", str(link), "--servos", "1-3,7", "--state", str(state))
    try:
        line = ready_line(process)
        assert line.startswith(f"emulating servos 1-3,7 (LX-16A) on {link} -> /dev/")
        assert line.rstrip().endswith("; Ctrl-C to stop")
        assert os.path.islink(link)
        with serial.Serial(str(link), 9600, timeout=2) as port:  # any baud setting works
            port.write(encode_request(C.POS_READ, 7))
            reply = port.read(8)
            port.write(encode_request(C.ID_WRITE, 2, new_id=9))
            port.write(encode_request(C.ID_READ, 9))
            id_reply = port.read(7)
    finally:
        returncode, stderr = stop(process)
    (packet,) = PacketDecoder().feed(reply)
    assert packet.servo_id == 7 and decode_reply(C.POS_READ, packet) == {"pos_units": 500}
    assert id_reply == bytes.fromhex("55 55 09 04 0E 09 DB")
    assert returncode == 130, stderr  # as a shell reports Ctrl-C; cleaned up all the same
    assert not os.path.lexists(link)
    saved = json.loads(state.read_text())
    assert [s["eeprom"]["servo_id"] for s in saved["servos"]] == [1, 9, 3, 7]


def test_sighup_exits_cleanly_like_sigterm(link, tmp_path):
    state = tmp_path / "state.json"
    process = start_emulator("--pty", str(link), "--servos", "1", "--state", str(state))
    try:
        ready_line(process)
    finally:
        returncode, stderr = stop(process, signal.SIGHUP)
    assert (returncode, stderr) == (128 + signal.SIGHUP, "")
    assert not os.path.lexists(link) and state.exists()


def test_sigterm_also_exits_cleanly_and_echo_works(link):
    process = start_emulator("--pty", str(link), "--servos", "1", "--echo")
    try:
        ready_line(process)
        with serial.Serial(str(link), 115200, timeout=2) as port:
            request = encode_request(C.TEMP_READ, 1)
            port.write(request)
            data = port.read(len(request) + 7)
    finally:
        returncode, stderr = stop(process, signal.SIGTERM)
    assert data[: len(request)] == request
    assert data[len(request) :] == bytes.fromhex("55 55 01 04 1A 1E C2")  # 30 °C
    assert returncode == 128 + signal.SIGTERM, stderr
    assert not os.path.lexists(link)


def test_signals_blocked_by_the_parent_still_stop_it(link):
    """A parent that blocked SIGINT and SIGTERM (as some libraries do in the thread that starts
    a process) passes the mask on through fork and exec; choreo unblocks them, so it stops."""
    blocked = {signal.SIGINT, signal.SIGTERM}
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "emulate", "--pty", str(link), "--servos", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
        preexec_fn=lambda: signal.pthread_sigmask(signal.SIG_BLOCK, blocked),
    )
    ready_line(process)
    returncode, stderr = stop(process, signal.SIGTERM)
    assert returncode == 128 + signal.SIGTERM, stderr


def test_an_existing_path_is_refused_and_left_alone(link, capsys):
    link.write_text("not a tty")
    assert main(["emulate", "--pty", str(link)]) == 1
    assert f"choreo: error: {link} already exists; remove it or choose another path (--pty)\n" in (
        capsys.readouterr().err
    )
    assert link.read_text() == "not a tty"


def replaced_note(link, target: str) -> str:
    return f"choreo: note: replaced {link}, left linking to {target} by an emulator that is gone\n"


def test_the_link_of_a_killed_emulator_to_the_pty_it_gets_again_is_replaced(link, monkeypatch):
    """A dead emulator's pty number goes to the next pty opened: often the new bridge's."""
    from choreo.emulator import BusEmulator
    from choreo.emulator import pty as pty_module

    master, slave = os.openpty()
    left = os.ttyname(slave)
    os.symlink(left, link)  # as an emulator killed with SIGKILL leaves it
    monkeypatch.setattr(pty_module.os, "openpty", lambda: (master, slave))
    with pty_module.PtyBridge(BusEmulator([1]), link) as bridge:
        assert bridge.replaced_target == left
        assert os.readlink(link) == bridge.slave_name == left
    assert not os.path.lexists(link)


@pytest.mark.parametrize("pty_of_a_terminal", [False, True])
def test_a_link_to_a_pty_no_emulator_serves_is_replaced_with_a_note(link, pty_of_a_terminal):
    """The pty a killed emulator's link names is gone, or now someone else's (not a bridge)."""
    terminal = os.openpty() if pty_of_a_terminal else None
    left = os.ttyname(terminal[1]) if terminal else "/dev/pts/999999"
    os.symlink(left, link)
    process = start_emulator("--pty", str(link))
    try:
        ready = ready_line(process)
        served = os.readlink(link)
    finally:
        returncode, stderr = stop(process)
        for fd in terminal or ():
            os.close(fd)
    assert served != left and ready.endswith(f"-> {served}; Ctrl-C to stop\n")
    assert (returncode, stderr) == (130, replaced_note(link, left))
    assert not os.path.lexists(link)


def test_the_link_of_a_running_emulator_is_refused_and_left_alone(link, capsys):
    running = start_emulator("--pty", str(link))
    try:
        ready_line(running)
        target = os.readlink(link)
        assert main(["emulate", "--pty", str(link)]) == 1  # the second, here
        assert capsys.readouterr().err == (
            f"choreo: error: {link} already links to {target}, which another emulator serves; "
            "stop that one, or choose another path (--pty)\n"
        )
        assert os.readlink(link) == target
    finally:
        stop(running)


def test_a_link_to_anything_but_a_pty_is_refused_and_left_alone(link, tmp_path, capsys):
    os.symlink(tmp_path / "gone", link)
    assert main(["emulate", "--pty", str(link)]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: {link} already exists; remove it or choose another path (--pty)\n"
    )
    assert os.readlink(link) == str(tmp_path / "gone")


def test_bad_servo_list_is_a_usage_error(link, capsys):
    with pytest.raises(SystemExit) as exited:
        main(["emulate", "--pty", str(link), "--servos", "1-x"])
    assert exited.value.code == 2
    assert "bad servo IDs" in capsys.readouterr().err


@pytest.mark.parametrize("option,gap_s", [((), 0.0), (("--start-gap-ms", "1.5"), 0.0015)])
def test_the_start_gap_fault_is_an_emulate_option_off_by_default(option, gap_s):
    from choreo.cli import build_parser
    from choreo.cli.emulate_commands import build_emulator

    args = build_parser().parse_args(["emulate", "--pty", "/tmp/unused", *option])
    assert {s.start_gap_s for s in build_emulator(args).servos} == {gap_s}
