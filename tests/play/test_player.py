"""The player on the emulator in virtual time: synchronized starts, path error, safety aborts."""

from __future__ import annotations

import pytest
from play_helpers import MOTIONS, Rig

from choreo.bus.protocol import Command, decode_request
from choreo.plan.ticks import QUANTIZATION_DEG
from choreo.play.path_errors import measured_path_errors
from choreo.play.play_options import ExitMode, PlayOptions
from choreo.play.report import Outcome


@pytest.mark.parametrize(
    "motion",
    [
        "arm6/wave.yaml",
        "arm6/dance.yaml",
        "hexapod18/tripod_gait.yaml",
        "tonypi/twist.yaml",
        "tonypi/turn_left.yaml",
    ],
)  # with ticks that change nothing
def test_executed_path_stays_within_tolerance_of_the_plan(motion):
    rig = Rig(f"{MOTIONS}/{motion}")
    report = rig.play()
    assert report.outcome is Outcome.COMPLETED
    assert report.retargeted == 0 and max(report.lateness_ms) == 0.0  # virtual time is exact
    errors = measured_path_errors(
        rig.emulator.log.moves, rig.robot, rig.performance, report, rig.start
    )
    assert max(errors) <= 0.5 + QUANTIZATION_DEG + 1e-6
    # and the servos end where the motion ends
    final = rig.performance.trajectory.at(rig.performance.trajectory.duration_s)[0]
    for joint, angle in zip(rig.robot.joints, final):
        assert joint.to_deg(rig.emulator.servo(joint.servo_id).position_units) == pytest.approx(
            angle, abs=QUANTIZATION_DEG + 1e-6
        )


def test_every_packet_on_the_wire_is_valid_and_in_range():
    rig = Rig(f"{MOTIONS}/arm6/pick_and_place.yaml")
    rig.play()
    for received in rig.emulator.log.packets:
        fields = decode_request(received.packet)  # raises on a malformed packet
        if "pos_units" in fields:
            assert 0 <= fields["pos_units"] <= 1000 and 0 <= fields["time_ms"] <= 30000


def test_ctrl_c_stops_at_once_and_unloads_when_asked():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    pressed = []

    def ctrl_c(progress):
        if progress.tick == 12:
            pressed.append(rig.clock.now())
            raise KeyboardInterrupt

    report = rig.play(options=PlayOptions(exit_mode=ExitMode.UNLOAD), on_progress=ctrl_c)
    assert report.outcome is Outcome.INTERRUPTED
    [stop] = rig.packets(Command.MOVE_STOP)
    assert stop.time_s - pressed[0] < 0.001
    assert not any(s.loaded for s in rig.emulator.servos)


def test_exit_pose_after_the_motion():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.play(options=PlayOptions(exit_mode=ExitMode.POSE, exit_pose="rest"))
    for joint, angle in zip(rig.robot.joints, rig.robot.pose_vector("rest")):
        assert joint.to_deg(rig.emulator.servo(joint.servo_id).position_units) == pytest.approx(
            angle, abs=QUANTIZATION_DEG + 1e-6
        )


def test_approach_from_anywhere_never_jumps():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml", pose="rest")
    rig.play()
    approach = rig.performance.approach
    assert approach.duration_ms > 0
    moves = [m for m in rig.emulator.log.moves if m.command == Command.MOVE_START]
    top_speed = max(abs(m.to_units - m.from_units) / m.duration_s for m in moves if m.duration_s)
    limit_units_s = max(j.limits.vel_deg_s for j in rig.robot.joints) * 1000 / 240
    assert top_speed <= limit_units_s * 1.05


def test_every_start_is_timed_when_its_bytes_were_written():
    """The times a show reports (choreo.show.performer): per START, when it was due, when its
    bytes were due to be written and when writing them returned, on the player's clock."""
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    report = rig.play()
    starts = rig.packets(Command.MOVE_START)
    assert len(report.start_times) == len(starts) == len(report.lateness_ms) > 0
    for timing, packet in zip(report.start_times, starts):
        # in virtual time the write takes no time and its last byte arrives at the deadline
        assert timing.write_at_s == timing.written_s < timing.deadline_s
        assert packet.time_s == pytest.approx(timing.deadline_s)
        assert timing.late_ms == 0.0
    deadlines = [t.deadline_s for t in report.start_times]
    assert deadlines == sorted(deadlines) and deadlines[0] == report.start_time_s
