"""choreo.play.tick_sending: the way ticks go out, chosen once from the transport's capabilities,
and what each way costs the deadline loop."""

from __future__ import annotations

import pytest
from emulated import recorded_writes

from choreo.bus.protocol import BROADCAST_ID, BYTE_TIME_S, Command, encode_request
from choreo.bus.servo_bus import ServoBus
from choreo.plan.ticks import MOVE_BYTES, START_BYTES, Tick
from choreo.play.tick_sending import MoveFrames, StagedStart, staged_moves, tick_sending
from choreo.robot.robot_file import load_robot

ARM = load_robot("arm6")
HOME = tuple(round(u) for u in ARM.to_units(ARM.pose_vector("home")))


def moved(*changed: int) -> Tick:
    """A 100 ms tick from home that moves the servos at these joint indices 40 units."""
    targets = tuple(u + 40 if i in changed else u for i, u in enumerate(HOME))
    return Tick(0, 100, targets, tuple(i in changed for i in range(len(HOME))))


def sent(bus: ServoBus, command: Command) -> list:
    return [p.packet for p in bus.emulator.log.packets if p.packet.command == command]


@pytest.mark.parametrize(
    "port, kind",
    [("sim://?ids=1-6&clock=virtual", StagedStart), ("sim://?board=rrc&ids=1-6", MoveFrames)],
)
def test_the_transport_chooses_the_way(port, kind):
    with ServoBus(port) as bus:
        assert type(tick_sending(bus, ARM)) is kind


def test_only_the_servos_whose_target_changes_are_staged_unless_all_are_asked_for():
    tick = moved(1, 4)
    assert [(j.name, pos) for j, pos, _ in staged_moves(tick, ARM)] == [
        (ARM.joints[1].name, HOME[1] + 40),
        (ARM.joints[4].name, HOME[4] + 40),
    ]
    assert len(list(staged_moves(tick, ARM, all_servos=True))) == 6
    assert {time_ms for _, _, time_ms in staged_moves(tick, ARM, all_servos=True)} == {100}


def test_staged_start_stages_the_moves_then_starts_them_with_one_broadcast():
    with ServoBus("sim://?ids=1-6&clock=virtual") as bus:
        sending = tick_sending(bus, ARM)
        tick = moved(0, 2)
        assert sending.stage(tick, all_servos=False) == 2 * MOVE_BYTES
        assert sending.start(tick, sending.moves(tick, all_servos=False)) == (START_BYTES, None)
        bus.drain()
        assert [p.servo_id for p in sent(bus, Command.MOVE_TIME_WAIT_WRITE)] == [1, 3]
        assert [p.servo_id for p in sent(bus, Command.MOVE_START)] == [BROADCAST_ID]
        assert sending.start_lead_s(6) == START_BYTES * BYTE_TIME_S
        assert sending.first_lead_s() == sending.restage_s() == 6 * MOVE_BYTES * BYTE_TIME_S
        assert sending.link_free_s(1.0, 2.0) == 1.0  # a START never waits for the wire
        assert sending.start_skew_ms() == 0.0


@pytest.mark.parametrize("all_servos", [False, True])
def test_a_staged_tick_goes_out_in_one_write_of_the_packets_stage_move_would_send(all_servos):
    tick = moved(4, 1, 5)
    wires = []
    for stage in ("tick", "servo by servo"):
        with ServoBus("sim://?ids=1-6&clock=virtual") as bus:
            writes = recorded_writes(bus)
            if stage == "tick":
                count = tick_sending(bus, ARM).stage(tick, all_servos=all_servos)
            else:
                for joint, pos, time_ms in staged_moves(tick, ARM, all_servos=all_servos):
                    bus.stage_move(joint.servo_id, pos, time_ms)
            bus.drain()
            wires.append((writes, [p.packet for p in bus.emulator.log.packets]))
    (tick_writes, tick_wire), (servo_writes, servo_wire) = wires
    assert len(tick_writes) == 1 and len(servo_writes) == (6 if all_servos else 3)
    assert tick_writes == [b"".join(servo_writes)] and count == len(tick_writes[0])
    # on the wire: the same packets, in joint order, every one a staged move of the tick
    assert tick_wire == servo_wire
    expected = [(j.servo_id, pos) for j, pos, _ in staged_moves(tick, ARM, all_servos=all_servos)]
    assert [p.encode() for p in tick_wire] == [
        encode_request(Command.MOVE_TIME_WAIT_WRITE, i, pos_units=pos, time_ms=100)
        for i, pos in expected
    ]
    assert [i for i, _ in expected] == ([1, 2, 3, 4, 5, 6] if all_servos else [2, 5, 6])


def test_move_frames_send_nothing_ahead_and_one_frame_at_the_start():
    with ServoBus("sim://?board=rrc&ids=1-6&clock=virtual") as bus:
        sending = tick_sending(bus, ARM)
        assert isinstance(sending, MoveFrames)
        tick = moved(0, 2, 5)
        assert sending.stage(tick, all_servos=True) == 0
        count, busy_s = sending.start(tick, sending.moves(tick, all_servos=False))
        assert count > 0 and busy_s == sending.frame_busy_s(count, 3)
        bus.drain()
        bus.emulator.clock.advance(0.1)  # the board forwards the frame one servo at a time
        moves = sent(bus, Command.MOVE_TIME_WRITE)
        assert [p.servo_id for p in moves] == [1, 3, 6]
        cap = bus.capabilities
        # the starts, one servo after another, are centred on the deadline
        assert sending.start_lead_s(3) == sending.frame_lead_s(3) + cap.start_skew_s(3) / 2
        assert sending.first_lead_s() == sending.start_lead_s(6)
        assert sending.link_free_s(1.0, 2.0) == 2.0  # a frame waits for the ones before it
        assert sending.start_skew_ms() == pytest.approx(cap.start_skew_s(3) * 1000)
