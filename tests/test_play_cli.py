"""`choreo play` as a user runs it: a subprocess on a pty emulator, interrupted with SIGINT; the
dry run; the built-in emulated bus. The SIGINT test runs on the real clock by necessity."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest
from emulated import wait_for

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.cli import main


def test_sigint_sends_move_stop_within_50_ms_and_exits_130(arm_on_a_pty):
    emulator, link = arm_on_a_pty
    # A generous read timeout: on a loaded machine the bridge thread may answer late, and this
    # test is about the stop, not about read latency.
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "choreo",
            "play",
            "motions/arm6/dance.yaml",
            "--port",
            str(link),
            "--timeout-ms",
            "500",
            "--health-timeout-ms",
            "100",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:

        def playing():
            if process.poll() is not None:
                raise AssertionError(f"choreo play exited early: {process.communicate()[1]}")
            # list() copies at once: the bridge thread appends to the log meanwhile
            starts = [
                p for p in list(emulator.log.packets) if p.packet.command == Command.MOVE_START
            ]
            return len(starts) >= 5

        wait_for(playing, "the motion to be playing")
        pressed_s = time.monotonic()
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130, stderr
    stops = [p for p in list(emulator.log.packets) if p.packet.command == Command.MOVE_STOP]
    assert stops and stops[0].packet.servo_id == BROADCAST_ID
    assert stops[0].time_s - pressed_s < 0.050
    assert "Traceback" not in stderr


def test_dry_run_prints_the_packet_schedule(capsys):
    assert main(["play", "motions/arm6/wave.yaml", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "no port opened" in out
    assert "55 55 fe 03 0b f3  START tick 0" in out
    assert "stage base_yaw" in out or "stage shoulder" in out


def test_play_on_the_built_in_emulated_bus(capsys):
    assert main(["play", "motions/arm6/wave.yaml", "--speed", "2", "--stretch"]) == 0
    captured = capsys.readouterr()
    assert "built-in emulated bus" in captured.err
    assert "completed" in captured.out and "path err" in captured.out


def test_bad_arguments_are_usage_errors(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["play", "motions/arm6/wave.yaml", "--speed", "0"])
    assert exit_info.value.code == 2
    assert "expected a number > 0, got '0'" in capsys.readouterr().err
    assert main(["play", "motions/arm6/wave.yaml", "--exit", "pose", "--exit-pose", "nope"]) == 2
    assert "'nope' is not a pose of arm6; poses: home, rest, ready" in capsys.readouterr().err


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
