"""One joint's test moves on an emulated bus in virtual time: each command sent at the first gap
after its time and stamped when it really went, the position read back to back in between, the
supply and temperature every half second."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, connection
from choreo.identify.joint_model import SentMove
from choreo.identify.measure import SLOW_READ_S, Neighbour, run_moves
from choreo.identify.moves import MovePlan
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")


def test_the_moves_go_on_their_times_and_the_reads_follow_the_servo():
    elbow = ARM6.joint("elbow")
    emulator = BusEmulator(
        [ServoSpec(elbow.servo_id, elbow.servo_model, position_units=elbow.to_units(0.0))],
        clock=VirtualClock(),
    )
    bus = ServoBus(connection(emulator))
    plan = MovePlan((SentMove(0.1, 20.0, 0.3), SentMove(0.8, 0.0, 0.3)), 1.5)
    measured = run_moves(bus, elbow, plan, start_setpoint_deg=0.0)
    sent = measured.trial.commands
    assert [round(c.target_deg) for c in sent] == [20, 0]
    # each goes at the first gap after its time: later, by less than one read exchange
    for asked, went in zip(plan.commands, sent):
        assert asked.at_s <= went.at_s < asked.at_s + 0.005
    reads_s, reads_deg = measured.trial.read_s, measured.trial.read_deg
    assert np.all(np.diff(reads_s) > 0) and measured.failed_reads == 0
    # back to back at 115200 baud: a POS_READ and its reply take ~1.8 ms
    assert 400 < measured.reads_per_s < 700
    at_target = reads_deg[(reads_s > 0.5) & (reads_s < 0.8)]
    assert np.allclose(at_target, 20.0, atol=0.3)
    assert np.allclose(reads_deg[reads_s > 1.2], 0.0, atol=0.3)
    # the slow reads: one at the start and one every SLOW_READ_S after
    assert len(measured.supply_v) == len(measured.temp_c) == int(1.5 / SLOW_READ_S)
    # the supply reads go to the fit with their times, to set its sag against the load
    supply = measured.trial.supply
    assert supply is not None and list(supply.volts) == list(measured.supply_v)
    assert np.diff(supply.read_s) == pytest.approx(
        [SLOW_READ_S] * (len(supply.read_s) - 1), abs=0.005
    )


def test_the_neighbours_are_read_every_fourth_read_and_the_joint_keeps_the_rest():
    names = ("shoulder", "elbow", "wrist_pitch")
    held = {"shoulder": 10.0, "elbow": 0.0, "wrist_pitch": -20.0}
    joints = {name: ARM6.joint(name) for name in names}
    emulator = BusEmulator(
        [
            ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(held[name]))
            for name, j in joints.items()
        ],
        clock=VirtualClock(),
    )
    bus = ServoBus(connection(emulator))
    plan = MovePlan((SentMove(0.1, 20.0, 0.3),), 1.0)
    neighbours = [Neighbour(joints[name], held[name]) for name in ("shoulder", "wrist_pitch")]
    measured = run_moves(bus, joints["elbow"], plan, 0.0, neighbours=neighbours)
    trial = measured.trial
    assert [n.joint for n in trial.neighbours] == ["shoulder", "wrist_pitch"]
    own = len(trial.read_s)
    for reads in trial.neighbours:
        assert len(reads.read_s) == pytest.approx(own / 2, abs=2)
        assert np.allclose(reads.read_deg, held[reads.joint], atol=0.3)
        assert reads.moved_deg < 0.3 and reads.held_deg == held[reads.joint]
    # in turn: between two of a neighbour's reads, two of the joint's
    shoulder = trial.neighbours[0].read_s
    between = np.histogram(trial.read_s, bins=shoulder)[0]
    assert np.all(between == 2)
    # the transport's rate is shared, not lost
    assert 400 < measured.reads_per_s < 700
    assert np.allclose(trial.read_deg[trial.read_s > 0.7], 20.0, atol=0.3)
    # one neighbour: still every fourth read, the joint keeps the rest
    alone = run_moves(bus, joints["elbow"], plan, 20.0, neighbours=neighbours[:1]).trial
    (shoulder_reads,) = alone.neighbours
    assert len(alone.read_s) == pytest.approx(3 * len(shoulder_reads.read_s), abs=3)
