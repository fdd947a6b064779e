"""`choreo play` as a user runs it: a subprocess on a pty emulator, interrupted with SIGINT; the
dry run; the built-in emulated bus. The signal test runs on the real clock by necessity, and
checks what reaches the wire and in which order, never how soon."""

from __future__ import annotations

import signal

import pytest
from cli_helpers import WAVE, choreo_process, motion_file, packets, play_here_then_signal
from emulated import PATIENT_READS, play_then_signal, wait_for

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.cli import main

MOVES = (Command.MOVE_TIME_WRITE, Command.MOVE_TIME_WAIT_WRITE, Command.MOVE_START)


# Ctrl-C to a `choreo play` process of its own; SIGHUP to this process, playing here (a process
# costs 0.8 s of CPU to start): the command's own handler must take it
@pytest.mark.parametrize("signum, here", [(signal.SIGINT, False), (signal.SIGHUP, True)])
def test_a_signal_puts_move_stop_on_the_wire_and_exits_130(arm_on_a_pty, signum, here, monkeypatch):
    """Order and content, not time (benchmarks/bench_stop.py prints how soon the stop comes)."""
    emulator, link = arm_on_a_pty

    def playing(log: list) -> bool:  # the approach and two ticks
        return sum(p.packet.command == Command.MOVE_START for p in log) >= 3

    if here:
        returncode, stderr, logged = play_here_then_signal(
            monkeypatch, emulator, str(link), signum, playing
        )
    else:
        returncode, stderr, logged = play_then_signal(emulator, str(link), signum, playing)
    assert returncode == 130, stderr
    assert "Traceback" not in stderr
    after = [p.packet for p in logged]
    stops = [i for i, packet in enumerate(after) if packet.command == Command.MOVE_STOP]
    assert stops and after[stops[0]].servo_id == BROADCAST_ID
    # the stop is the last thing that moves the servos: nothing after it starts a move
    assert not [p.command.name for p in after[stops[0] :] if p.command in MOVES]


def test_dry_run_prints_the_packet_schedule(capsys):
    assert main(["play", "motions/arm6/wave.yaml", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "no port opened" in out
    assert "55 55 fe 03 0b f3  START tick 0" in out
    assert "stage base_yaw" in out or "stage shoulder" in out


def test_play_on_the_built_in_emulated_bus(capsys, virtual_built_in_emulator):
    assert main(["play", "motions/arm6/wave.yaml", "--speed", "2", "--stretch"]) == 0
    captured = capsys.readouterr()
    assert "built-in emulated bus" in captured.err
    assert "completed" in captured.out and "path err" in captured.out


def test_bad_arguments_are_usage_errors(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["play", "motions/arm6/wave.yaml", "--speed", "0"])
    assert exit_info.value.code == 2
    assert "expected a number >= 0.01 and <= 100, got '0'" in capsys.readouterr().err
    assert main(["play", "motions/arm6/wave.yaml", "--exit", "pose", "--exit-pose", "nope"]) == 2
    assert "'nope' is not a pose of arm6; poses: home, rest, ready" in capsys.readouterr().err


def test_an_exit_pose_without_exit_pose_is_refused_not_ignored(capsys):
    argv = ["play", "motions/arm6/wave.yaml", "--exit-pose", "ready"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err == (
        "choreo: error: --exit-pose ready is used only with --exit pose (now --exit hold): add "
        "--exit pose, or drop --exit-pose\n"
    )
    assert captured.out == ""  # refused before anything plays
    assert main([*argv, "--exit", "unload"]) == 2
    assert "(now --exit unload)" in capsys.readouterr().err


def test_an_infeasible_motion_is_refused_before_any_port_is_opened(capsys):
    assert (
        main(["play", "motions/arm6/wave.yaml", "--speed", "4", "--port", "/dev/does-not-exist"])
        == 1
    )
    err = capsys.readouterr().err
    assert "keyframe cannot be reached at 0.250 s (at speed 4)" in err and "cannot open" not in err


def test_the_robot_files_bus_settings_are_defaults_the_command_line_overrides():
    import argparse
    import dataclasses

    from choreo.bus.settings import BusSettings
    from choreo.cli.arguments import bus_settings
    from choreo.robot.robot_file import load_robot

    robot = dataclasses.replace(
        load_robot("arm6"),
        bus=BusSettings(port="/dev/ttyUSB7", timeout_s=0.1, retries=4, echo="none"),
    )
    nothing = argparse.Namespace(
        port=None, timeout_ms=None, retries=None, echo=None, direction=None
    )
    assert bus_settings(nothing, robot) == robot.bus
    assert bus_settings(nothing) == BusSettings()  # no robot: the defaults, the built-in bus
    given = argparse.Namespace(
        port="sim://?ids=1-6", timeout_ms=80.0, retries=None, echo="auto", direction="ainex"
    )
    assert bus_settings(given, robot) == BusSettings(
        port="sim://?ids=1-6", timeout_s=0.08, retries=4, echo="auto", direction="ainex"
    )


def test_a_port_lost_during_play_is_one_error_line_and_no_traceback(tmp_path):
    from emulated import home_specs, served_on_a_pty

    from choreo.core.clock import RealClock
    from choreo.emulator import BusEmulator
    from choreo.robot.robot_file import load_robot

    emulator = BusEmulator(home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyARM") as link:
        argv = ["play", "motions/arm6/dance.yaml", "--port", str(link)]
        process = choreo_process(*argv, *PATIENT_READS)

        def playing():
            assert process.poll() is None, process.communicate()
            return len(packets(emulator, "MOVE_START")) >= 3  # the approach and two ticks

        try:
            wait_for(playing, "the motion to be playing")
        except BaseException as error:
            process.kill()
            if isinstance(error, AssertionError) and process.stderr and not process.stderr.closed:
                raise AssertionError(f"{error}; choreo said: {process.stderr.read()}") from None
            raise
    # the pty is gone, as when the USB adapter is pulled
    try:
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 1
    assert "Traceback" not in stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith(f"choreo: error: {link}: the port was lost (")
    assert last.endswith("): check the USB cable")


def test_play_on_a_virtual_clock_sim_url_completes(capsys):
    """The README's clock=virtual: the player keeps the emulator's time, so nothing lags."""
    assert main(["play", str(WAVE), "--port", "sim://?ids=1-6&clock=virtual"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("completed\n") and "away from where it should be" not in out


def test_play_stretch_says_how_much(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    argv = ["play", str(path), "--stretch", "--port", "sim://?ids=1-6&clock=virtual"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"{path}:5:5: stretched: reached 0.367 s later than written\n" in err


def test_a_play_refused_before_anything_moves_is_its_one_line_without_a_progress_bar(capsys):
    """The bar comes with the first move: none stands at "approach" over a refusal."""
    dance = "motions/arm6/dance.yaml"
    argv = ["play", dance, "--loop", "3", "--no-audio", "--port", "sim://?ids=1-6&clock=virtual"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("choreo: error: --loop 3: the dance (repeat 3) runs to at least t ")
    assert err.count("\n") == 1
