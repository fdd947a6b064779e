"""choreo.play.stream: the deadline loop on the emulator in virtual time: starts on their
deadlines, together, never missed; falling behind re-targets instead of replaying."""

from __future__ import annotations

import pytest
from emulated import recorded_writes
from play_helpers import MOTIONS, Rig

from choreo.bus.protocol import BROADCAST_ID, Command, encode_request
from choreo.plan.ticks import MOVE_BYTES, QUANTIZATION_DEG, Tick
from choreo.play.dry_run import packet_schedule
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import preflight
from choreo.play.report import Outcome


@pytest.mark.parametrize("motion", ["arm6/wave.yaml", "hexapod18/tripod_gait.yaml"])
def test_the_player_leaves_the_start_gap_so_no_start_is_missed(motion):
    # With the emulator's START-gap fault on, a START sent right after a staged move is missed:
    # the player must still get every servo moving exactly as with the fault off.
    started = []
    for start_gap_s in (0.0, 0.001):
        rig = Rig(f"{MOTIONS}/{motion}", start_gap_s=start_gap_s)
        assert rig.play().outcome is Outcome.COMPLETED
        moves = [m for m in rig.emulator.log.moves if m.command == Command.MOVE_START]
        started.append([(m.servo_id, m.time_s - rig.report.start_time_s) for m in moves])
    assert len(started[0]) > 100
    assert started[1] == started[0]


def test_all_servos_of_a_tick_start_at_the_same_instant():
    rig = Rig(f"{MOTIONS}/hexapod18/tripod_gait.yaml")
    rig.play()
    starts = [m for m in rig.emulator.log.moves if m.command == Command.MOVE_START]
    by_time: dict[float, set[int]] = {}
    for move in starts:
        by_time.setdefault(move.time_s, set()).add(move.servo_id)
    start_packets = rig.packets(Command.MOVE_START)
    assert all(p.packet.servo_id == BROADCAST_ID for p in start_packets)
    # every move began at the arrival of a broadcast START, never servo by servo
    assert set(by_time) <= {p.time_s for p in start_packets}
    assert max(len(ids) for ids in by_time.values()) == 18
    # each START arrives on its tick's deadline
    deadlines = {
        round(rig.report.start_time_s + t.start_ms / 1000, 9) for t in rig.performance.ticks
    }
    assert {round(p.time_s, 9) for p in start_packets} <= deadlines


def test_falling_behind_retargets_instead_of_replaying_stale_ticks():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")

    def stall_the_host(progress):
        if progress.tick == 6:
            rig.clock.advance(0.5)  # the host froze for half a second

    report = rig.play(on_progress=stall_the_host)
    assert report.outcome is Outcome.COMPLETED and report.retargeted == 1
    assert report.ticks_played == report.ticks_total
    stale = [m for m in rig.emulator.log.moves if 0 < m.time_s - progress_time(rig, 6) < 0.5]
    assert not stale  # nothing was started while the host was frozen: no stale tick replayed
    final = rig.performance.trajectory.at(rig.performance.trajectory.duration_s)[0]
    for joint, angle in zip(rig.robot.joints, final):  # the re-targeted START was not missed
        assert joint.to_deg(rig.emulator.servo(joint.servo_id).position_units) == pytest.approx(
            angle, abs=QUANTIZATION_DEG + 1e-6
        )


def progress_time(rig, tick):
    return rig.report.start_time_s + rig.performance.ticks[tick - 1].start_ms / 1000


def test_a_retarget_onto_a_tick_that_changes_nothing_still_starts_it():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    start, limits = preflight(rig.bus, rig.robot)
    here = tuple(round(j.to_units(a)) for j, a in zip(rig.robot.joints, start))
    there = (here[0] + 40,) + here[1:]  # base_yaw 9.6° further, then 19.2°
    further = (here[0] + 80,) + here[1:]
    all_, none = (True,) * 6, (False,) * 6
    ticks = [
        Tick(0, 100, there, all_),
        Tick(100, 100, further, all_),
        Tick(200, 400, further, none),  # stay: nothing to stage, no START needed
        Tick(600, 100, here, all_),
    ]  # then back

    def freeze(progress):
        if progress.tick == 1:
            rig.clock.advance(0.25)  # the host wakes up inside the tick that changes nothing

    report = Player(rig.bus, rig.robot, rig.clock, limits, on_progress=freeze).play(ticks, start)
    assert report.outcome is Outcome.COMPLETED and report.retargeted == 1
    starts = rig.packets(Command.MOVE_START)
    assert len(starts) == 3  # tick 0, the re-targeted tick 2 (it was re-staged), tick 3
    reached = [m.to_units for m in rig.emulator.log.moves if m.servo_id == 1]
    assert further[0] in reached  # the re-targeted tick really moved the servo
    assert rig.emulator.servo(1).position_units == pytest.approx(here[0])


def test_each_tick_is_staged_in_one_write_and_the_wire_is_the_dry_runs():
    """The staged moves of each tick leave in one write (one system call; behind direction lines
    one transmit window), and what reaches the servos is the dry run's packets in its order."""
    rig = Rig(f"{MOTIONS}/hexapod18/tripod_gait.yaml")
    writes = recorded_writes(rig.bus)
    rig.play(options=PlayOptions(health_timeout_s=5.0))  # no time for health reads
    start = encode_request(Command.MOVE_START, BROADCAST_ID)
    expected: list[bytes] = []  # the dry run, each run of staged moves as one write
    for p in packet_schedule(rig.performance.ticks, rig.robot):
        if expected and start not in (p.packet, expected[-1]):
            expected[-1] += p.packet
        else:
            expected.append(p.packet)
    played = writes[writes.index(expected[0]) :]  # from tick 0's staging (after preflight)
    assert played == expected
    assert len(played[0]) == 18 * MOVE_BYTES  # tick 0: every servo, at once
    # and the servos received exactly those packets, whole and in that order
    staging = (Command.MOVE_START, Command.MOVE_TIME_WAIT_WRITE)
    received = [p.packet.encode() for p in rig.emulator.log.packets if p.packet.command in staging]
    assert b"".join(received) == b"".join(expected)


def test_the_next_tick_is_staged_before_progress_and_health_reads():
    """What the next START needs goes first, right after a START: its staged moves; then the
    progress callback and health reads, in the time left (they never delay the staging)."""
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    events: list[str] = []

    def recorded(name, method):
        def call(*args, **kwargs):
            events.append(name)
            return method(*args, **kwargs)

        return call

    bus = rig.bus
    # one letter each: T a START, s a tick's staged moves, r a read, p a progress callback
    bus.start = recorded("T", bus.start)  # type: ignore[method-assign]
    bus.stage_many = recorded("s", bus.stage_many)  # type: ignore[method-assign]
    bus.request = recorded("r", bus.request)  # type: ignore[method-assign]
    rig.play(on_progress=lambda progress: events.append("p"))
    played = "".join(events[events.index("T") :])  # from the first START (after preflight)
    assert played.count("p") > 10 and "r" in played and "s" in played
    # after each progress, only reads until the next START: nothing staged late
    assert all("s" not in after.split("T")[0] for after in played.split("p")[1:])
    # and the staging came between the START and the progress, not after, in one call per tick
    assert "Tsp" in played and "ss" not in played
