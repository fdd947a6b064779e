"""choreo.play.health: the reads between ticks, on the emulator in virtual time: what they saw,
and the aborts a lost, hot, low or blocked servo causes (with MOVE_STOP)."""

from __future__ import annotations

import numpy as np
import pytest
from play_helpers import MOTIONS, Rig

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.bus.servo_bus import ServoBus
from choreo.emulator import ReplyFaults
from choreo.play.health import HealthReads, ServoHealth
from choreo.play.play_options import PlayOptions
from choreo.play.preflight import preflight
from choreo.play.report import Outcome
from choreo.robot.robot_file import load_robot


@pytest.mark.parametrize("echo_mode", ["auto", "none", "discard"])
def test_an_echoing_bus_plays_with_every_health_read_answered(echo_mode):
    # One-wire wiring: every staged move comes back before the reply to the next health read.
    rig = Rig(f"{MOTIONS}/hexapod18/tripod_gait.yaml", echo=True, bus_echo=echo_mode)
    report = rig.play()
    assert report.outcome is Outcome.COMPLETED, report.reason
    assert report.missed_reads == 0
    assert sum(h.reads for h in report.health) > 100


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


def test_a_servos_health_keeps_the_extremes_it_saw():
    health = ServoHealth("elbow", 3)
    for temp_c in (40, 35, 38):
        health.saw_temperature(temp_c)
    for vin_mv in (7400, 7200, 7300):
        health.saw_vin(vin_mv)
    for error_deg in (0.5, 0.2):
        health.saw_position_error(error_deg)
    assert (health.temp_c_min, health.temp_c_max) == (35, 40)
    assert (health.vin_mv_min, health.vin_mv_max) == (7200, 7400)
    assert health.position_error_deg_max == 0.5


def reads_made(port: str, count: int, budget_s: float = 1.0) -> list[tuple[Command, int]]:
    """The first ``count`` health reads of arm6 on ``port`` (its servos at 500 units)."""
    robot = load_robot("arm6")
    with ServoBus(port) as bus:
        _, limits = preflight(bus, robot)
        reads = HealthReads(bus, robot, limits, PlayOptions())
        bus.drain()  # preflight's loads reach the servos first
        before = len(bus.emulator.log.packets)
        made = [reads.read(budget_s, np.full(6, 500.0)) for _ in range(count)]
        assert made == [budget_s >= reads.cost_s] * count
        packets = list(bus.emulator.log.packets)[before:]
        return [(p.packet.command, p.packet.servo_id) for p in packets]


def test_positions_are_read_most_often_and_each_round_one_supply_and_temperature():
    position = [(Command.POS_READ, i) for i in range(1, 7)]
    assert reads_made("sim://?ids=1-6&clock=virtual", 16) == [
        *position,
        (Command.VIN_READ, 1),
        (Command.TEMP_READ, 1),
        *position,
        (Command.VIN_READ, 2),
        (Command.TEMP_READ, 2),
    ]


def test_only_what_the_transport_can_read_is_read():
    # the LOBOT controller reads positions only
    reads = reads_made("sim://?board=lobot&ids=1-6&clock=virtual", 8)
    assert {command for command, _ in reads} == {Command.POS_READ}
    assert [servo_id for _, servo_id in reads] == [1, 2, 3, 4, 5, 6, 1, 2]


def test_no_read_is_made_where_it_would_not_fit_before_the_next_start():
    options = PlayOptions()
    too_short_s = options.health_timeout_s + options.start_guard_s - 0.001
    assert reads_made("sim://?ids=1-6&clock=virtual", 3, budget_s=too_short_s) == []
