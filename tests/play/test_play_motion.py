"""choreo.play.play_motion: `choreo play` as one library call, on emulators in virtual time."""

from __future__ import annotations

import pytest
from cli_helpers import WAVE, error_line, motion_file
from emulated import home_specs

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.bus.servo_bus import ServoBus
from choreo.cli import main
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection
from choreo.errors import OptionError
from choreo.motion.motion_file import load_motion
from choreo.play.play_motion import play_motion
from choreo.play.play_options import ExitMode, PlayOptions
from choreo.play.report import Outcome

VIRTUAL_ARM = "sim://?ids=1-6&clock=virtual"


def arm_at_home() -> BusEmulator:
    return BusEmulator(home_specs(load_motion(WAVE).robot), clock=VirtualClock())


def test_a_path_is_loaded_played_and_reported_with_what_the_wire_shows():
    report = play_motion(str(WAVE), port=VIRTUAL_ARM)
    assert report.outcome is Outcome.COMPLETED
    assert report.ticks_played == report.ticks_total > 0
    assert (report.motion, report.robot, report.port) == (str(WAVE), "arm6", VIRTUAL_ARM)
    assert report.emulated and report.measured_start_skew_ms == 0.0  # one broadcast START
    assert report.path_errors_deg is not None and len(report.path_errors_deg) == 6
    assert max(report.path_errors_deg) < 2.0  # the servos followed the plan
    assert report.exit_move is None  # exit mode hold: no move after the motion


def test_a_bus_the_caller_opened_is_played_on_and_left_open():
    emulator = arm_at_home()
    with ServoBus(connection(emulator)) as bus:
        report = play_motion(load_motion(WAVE), port=bus)
        assert report.outcome is Outcome.COMPLETED
        assert bus.ping(1)  # still open
    starts = [p for p in emulator.log.packets if p.packet.command == Command.MOVE_START]
    assert len(starts) == len(report.lateness_ms) > 0  # every START the player timed
    assert all(p.packet.servo_id == BROADCAST_ID for p in starts)


def test_the_exit_pose_is_reached_after_the_motion():
    emulator = arm_at_home()
    options = PlayOptions(exit_mode=ExitMode.POSE, exit_pose="rest")
    report = play_motion(WAVE, port=ServoBus(connection(emulator)), options=options)
    assert report.exit_move is not None and report.exit_move.outcome is Outcome.COMPLETED
    robot = load_motion(WAVE).robot
    rest = [j.to_units(a) for j, a in zip(robot.joints, robot.pose_vector("rest"))]
    at = [emulator.servo(j.servo_id).position_units for j in robot.joints]
    assert at == pytest.approx(rest, abs=1)


def test_a_stretched_keyframe_is_told_before_anything_moves(tmp_path):
    path = motion_file(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    notes: list[str] = []
    options = PlayOptions(stretch=True)
    report = play_motion(path, port=VIRTUAL_ARM, options=options, on_note=notes.append)
    assert report.outcome is Outcome.COMPLETED
    assert f"{path}:5:5: stretched: reached 0.367 s later than written" in notes


def test_an_exit_pose_the_robot_lacks_names_the_argument_and_the_poses():
    with pytest.raises(OptionError) as raised:
        play_motion(WAVE, port=VIRTUAL_ARM, options=PlayOptions(exit_pose="nope"))
    assert raised.value.option == "exit_pose"
    assert raised.value.problem == "'nope' is not a pose of arm6; poses: home, rest, ready"


def test_loop_is_bounded_before_any_port_is_opened():
    options = PlayOptions(loop=10**8)
    with pytest.raises(OptionError) as raised:
        play_motion(WAVE, port="/dev/does-not-exist", options=options)
    assert raised.value.option == "loop"
    assert "at most 10000 are played in one motion" in raised.value.problem


def test_play_loop_is_bounded(capsys):
    assert main(["play", str(WAVE), "--loop", "100000000", "--dry-run"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --loop 100000000 x 9 keyframe(s) = 900000000 keyframes to play; at most "
        "10000 are played in one motion: at most 1111 times"
    )
