"""The player on the emulator in virtual time: synchronized starts, path error, safety aborts."""

from __future__ import annotations

import pytest

from choreo.bus.protocol import BROADCAST_ID, Command, decode_request
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ReplyFaults, ServoSpec, connection
from choreo.errors import ChoreoError
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.plan.ticks import QUANTIZATION_DEG, Tick
from choreo.play.path_errors import measured_path_errors
from choreo.play.player import ExitMode, Outcome, Player, PlayOptions, packet_schedule, preflight

MOTIONS = "motions"


class Rig:
    """A robot's servos on an emulated bus in virtual time, standing at ``pose``."""

    def __init__(
        self, motion_path, pose="home", skip_ids=(), echo=False, bus_echo="auto", start_gap_s=0.0
    ):
        self.motion = load_motion(motion_path)
        self.robot = self.motion.robot
        self.clock = VirtualClock()
        angles = self.robot.pose_vector(pose)
        specs = [
            ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
            for j, a in zip(self.robot.joints, angles)
            if j.servo_id not in skip_ids
        ]
        self.emulator = BusEmulator(specs, clock=self.clock, echo=echo, start_gap_s=start_gap_s)
        self.bus = ServoBus(connection(self.emulator, echo=bus_echo))

    def play(self, options=None, on_progress=None, **prepare_args):
        options = PlayOptions() if options is None else options
        self.start, limits = preflight(self.bus, self.robot)
        self.performance = prepare(compile_motion(self.motion, **prepare_args), self.start)
        player = Player(self.bus, self.robot, self.clock, limits, options, on_progress)
        self.report = player.play(self.performance.ticks, self.start)
        player.leave(self.report.outcome)
        return self.report

    def packets(self, command):
        return [p for p in self.emulator.log.packets if p.packet.command == command]


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


@pytest.mark.parametrize("echo_mode", ["auto", "none", "discard"])
def test_an_echoing_bus_plays_with_every_health_read_answered(echo_mode):
    # One-wire wiring: every staged move comes back before the reply to the next health read.
    rig = Rig(f"{MOTIONS}/hexapod18/tripod_gait.yaml", echo=True, bus_echo=echo_mode)
    report = rig.play()
    assert report.outcome is Outcome.COMPLETED, report.reason
    assert report.missed_reads == 0
    assert sum(h.reads for h in report.health) > 100


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


def test_every_packet_on_the_wire_is_valid_and_in_range():
    rig = Rig(f"{MOTIONS}/arm6/pick_and_place.yaml")
    rig.play()
    for received in rig.emulator.log.packets:
        fields = decode_request(received.packet)  # raises on a malformed packet
        if "pos_units" in fields:
            assert 0 <= fields["pos_units"] <= 1000 and 0 <= fields["time_ms"] <= 30000


def test_missing_servo_is_refused_by_name_before_anything_moves():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml", skip_ids=(3,))
    with pytest.raises(ChoreoError, match=r"1 servo\(s\) did not answer: elbow \(ID 3\)"):
        rig.play()
    assert not rig.emulator.log.moves


def test_servo_limits_narrower_than_the_robot_file_are_refused():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.bus.set_angle_limits(1, 300, 700)
    with pytest.raises(
        ChoreoError,
        match=r"base_yaw \(ID 1\): the servo's own angle limits 300..700 "
        r"are narrower than the robot file's 0..1000",
    ):
        rig.play()


def test_low_voltage_and_heat_are_refused_in_preflight():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.emulator.servo(2).vin_mv = 4000
    rig.emulator.servo(5).temperature_c = 90
    with pytest.raises(ChoreoError) as error:
        rig.play()
    assert "shoulder (ID 2): supply 4000 mV is outside" in str(error.value)
    assert "wrist_roll (ID 5): 90 °C is at or above the servo's limit 85 °C" in str(error.value)


def test_a_supply_outside_the_robot_files_servo_model_is_refused_in_preflight():
    # arm6 is LX-16A (rated 6-8.4 V, docs/servo-models.md); its stored limits are 4.5-14 V
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    assert rig.robot.joints[0].servo_model == "LX-16A"
    for servo in rig.emulator.servos:
        servo.vin_mv = 10800  # an 11.1 V (3S) pack
    with pytest.raises(ChoreoError) as error:
        rig.play()
    message = str(error.value)
    # one problem shared by every servo is one line naming them all, not one line each
    every = ", ".join(f"{j.name} (ID {j.servo_id})" for j in rig.robot.joints)
    assert f"{every}: supply 10.8 V is outside the LX-16A's rated 6-8.4 V" in message
    assert message.count("rated 6-8.4 V") == 1
    assert "the servo's limits" not in message  # the stored 4.5-14 V let it through
    assert not [p for p in rig.emulator.log.packets if p.packet.command.name.startswith("MOVE")]


def test_servo_vanishing_mid_play_aborts_with_move_stop():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    vanish_at = []

    def pull_the_cable(progress):
        if progress.tick == 10:
            rig.emulator.servo(4).connected = False
            vanish_at.append(rig.clock.now())

    report = rig.play(on_progress=pull_the_cable)
    assert report.outcome is Outcome.ABORTED
    assert "wrist_pitch (ID 4) stopped answering" in report.reason
    stops = rig.packets(Command.MOVE_STOP)
    assert stops and stops[-1].packet.servo_id == BROADCAST_ID
    assert stops[-1].time_s > vanish_at[0]
    assert report.ticks_played < report.ticks_total


def test_over_temperature_aborts():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")

    def heat_up(progress):
        if progress.tick == 5:
            rig.emulator.servo(2).temperature_c = 82  # 3 °C under its limit of 85

    report = rig.play(on_progress=heat_up)
    assert report.outcome is Outcome.ABORTED
    assert "shoulder (ID 2) is at 82 °C, near its limit 85 °C" in report.reason
    assert rig.packets(Command.MOVE_STOP)


def test_position_error_aborts():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")

    def hold_the_wrist(progress):
        # Somebody grabs the waving wrist at tick 8 and keeps it where it was.
        if progress.tick >= 8:
            servo = rig.emulator.servo(4)
            held = rig.held = getattr(rig, "held", servo.position_units)
            rig.bus.unload(4)
            rig.bus.drain()
            servo.move_by_hand(held)

    report = rig.play(options=PlayOptions(max_position_error_deg=10), on_progress=hold_the_wrist)
    assert report.outcome is Outcome.ABORTED
    assert (
        "wrist_pitch (ID 4) is" in report.reason and "away from where it should be" in report.reason
    )
    assert rig.packets(Command.MOVE_STOP)


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


def test_dry_run_schedule_matches_what_is_sent():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.play(options=PlayOptions(health_timeout_s=5.0))  # no time for health reads
    schedule = packet_schedule(rig.performance.ticks, rig.robot)
    sent = [
        p.packet.encode()
        for p in rig.emulator.log.packets
        if p.packet.command in (Command.MOVE_START, Command.MOVE_TIME_WAIT_WRITE)
    ]
    assert [p.packet for p in schedule] == sent


def test_a_garbled_health_read_is_tolerated_but_a_run_of_them_aborts():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")

    def noisy_wire(progress):
        if progress.tick == 3:
            rig.emulator.servo(2).reply_faults = ReplyFaults(corrupt_next=1)
        if progress.tick == 20:
            rig.emulator.servo(2).reply_faults = ReplyFaults(corrupt_probability=1.0)

    report = rig.play(on_progress=noisy_wire)
    assert report.outcome is Outcome.ABORTED
    assert (
        "shoulder (ID 2) stopped answering (3 reads in a row timed out or came back garbled); "
        "check its cable, or allow a slow USB adapter more time (health_timeout_s)" in report.reason
    )
    assert report.ticks_played >= 20  # the single garbled reply at tick 3 did not stop it


def test_low_voltage_mid_play_aborts():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")

    def brown_out(progress):
        if progress.tick == 5:
            rig.emulator.servo(3).vin_mv = 4200  # below the factory minimum of 4500 mV

    report = rig.play(on_progress=brown_out)
    assert report.outcome is Outcome.ABORTED
    assert "elbow (ID 3) supply is 4200 mV, outside 4500..14000 mV" in report.reason
    assert rig.packets(Command.MOVE_STOP)


def test_a_servo_in_motor_mode_is_refused_before_anything_moves():
    # MOVE_STOP cannot stop a servo in motor mode, so play must not start with one.
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.bus.set_motor_mode(5, 300)
    with pytest.raises(
        ChoreoError,
        match=r"wrist_roll \(ID 5\): is in motor mode \(turning at "
        r"duty 300\), which MOVE_STOP cannot stop; stop its motor first "
        r"\(choreo.bus.servo_config.stop_motor\)",
    ):
        rig.play()
    assert not [m for m in rig.emulator.log.moves if m.command == Command.MOVE_START]


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


def test_two_servos_sharing_an_id_are_refused_as_such():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.emulator = BusEmulator([*home_specs_of(rig.robot), ServoSpec(3)], clock=rig.clock)
    rig.bus = ServoBus(connection(rig.emulator))
    with pytest.raises(
        ChoreoError,
        match=r"1 servo\(s\) answered garbled, as when two servos "
        r"share an ID: elbow \(ID 3\)",
    ):
        rig.play()


def home_specs_of(robot):
    return [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, robot.pose_vector("home"))
    ]
