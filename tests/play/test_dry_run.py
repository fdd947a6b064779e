"""choreo.play.dry_run: the packets a play would send, without a port."""

from __future__ import annotations

from play_helpers import MOTIONS, Rig

from choreo.bus import transports
from choreo.bus.protocol import BROADCAST_ID, Command, encode_request
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.dry_run import frame_schedule, packet_schedule, schedule
from choreo.play.play_options import PlayOptions

WAVE = f"{MOTIONS}/arm6/wave.yaml"


def test_dry_run_schedule_matches_what_is_sent():
    rig = Rig(WAVE)
    rig.play(options=PlayOptions(health_timeout_s=5.0))  # no time for health reads
    planned = packet_schedule(rig.performance.ticks, rig.robot)
    sent = [
        p.packet.encode()
        for p in rig.emulator.log.packets
        if p.packet.command in (Command.MOVE_START, Command.MOVE_TIME_WAIT_WRITE)
    ]
    assert [p.packet for p in planned] == sent


def test_through_a_board_each_tick_is_the_move_frame_the_player_sends():
    motion = load_motion(WAVE)
    link = transports.link("rrc:///dev/ttyAMA0")
    ticks = prepare(compile_motion(motion), motion.robot.pose_vector("home")).ticks
    frames = schedule(ticks, motion.robot, link)
    assert frames == frame_schedule(ticks, motion.robot, link.move_frame)
    assert [f.time_ms for f in frames] == [
        t.start_ms for k, t in enumerate(ticks) if k == 0 or any(t.staged)
    ]
    first = ticks[0]
    every = [(j.servo_id, pos) for j, pos in zip(motion.robot.joints, first.targets_units)]
    assert frames[0].packet == link.move_frame(every, first.duration_ms)


def test_on_the_raw_bus_the_schedule_is_staged_moves_and_starts():
    motion = load_motion(WAVE)
    ticks = prepare(compile_motion(motion), motion.robot.pose_vector("home")).ticks
    packets = schedule(ticks, motion.robot, transports.link("/dev/ttyUSB0"))
    assert packets == packet_schedule(ticks, motion.robot)
    starts = [p for p in packets if p.packet == encode_request(Command.MOVE_START, BROADCAST_ID)]
    assert len(starts) == 1 + sum(any(t.staged) for t in ticks[1:])
