"""The dry run: every packet the player would send for a tick list, with its time, and no port
opened (``choreo play --dry-run``). Health reads are left out: they fill whatever bus time is
spare, which only a play can tell."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from choreo.bus.protocol import BROADCAST_ID, Command, encode_request
from choreo.bus.transports import Link
from choreo.plan.ticks import Tick
from choreo.play.tick_sending import staged_moves
from choreo.robot.types import Robot

MoveFrame = Callable[[Sequence[tuple[int, int]], int], bytes]  # a board's (moves, time_ms)


@dataclass(frozen=True)
class ScheduledPacket:
    time_ms: int  # when it is sent, from the first START
    packet: bytes
    description: str


def packet_schedule(ticks: Sequence[Tick], robot: Robot) -> list[ScheduledPacket]:
    """Every packet the player sends for ``ticks`` on the raw bus, in order: each tick's moves
    staged while the tick before runs, then its broadcast START."""
    schedule = []

    def stage(tick: Tick, at_ms: int, all_servos: bool) -> None:
        for joint, pos, time_ms in staged_moves(tick, robot, all_servos=all_servos):
            packet = encode_request(
                Command.MOVE_TIME_WAIT_WRITE, joint.servo_id, pos_units=pos, time_ms=time_ms
            )
            schedule.append(
                ScheduledPacket(at_ms, packet, f"stage {joint.name} -> {pos} in {time_ms} ms")
            )

    if ticks:
        stage(ticks[0], ticks[0].start_ms, all_servos=True)
    for k, tick in enumerate(ticks):
        if k == 0 or any(tick.staged):  # a tick that changes no target needs no START
            schedule.append(
                ScheduledPacket(
                    tick.start_ms,
                    encode_request(Command.MOVE_START, BROADCAST_ID),
                    f"START tick {k} ({tick.duration_ms} ms)",
                )
            )
        if k + 1 < len(ticks):
            stage(ticks[k + 1], tick.start_ms, all_servos=False)
    return schedule


def frame_schedule(
    ticks: Sequence[Tick], robot: Robot, move_frame: MoveFrame
) -> list[ScheduledPacket]:
    """The dry run through a board that cannot stage: one move frame per tick that changes a
    target, built by the board's ``move_frame(moves, time_ms)``, at the tick's start."""
    schedule = []
    for k, tick in enumerate(ticks):
        moves = [(j.servo_id, pos) for j, pos, _ in staged_moves(tick, robot, all_servos=k == 0)]
        if moves:
            schedule.append(
                ScheduledPacket(
                    tick.start_ms,
                    move_frame(moves, tick.duration_ms),
                    f"tick {k}: move {len(moves)} servo(s) in {tick.duration_ms} ms",
                )
            )
    return schedule


def schedule(ticks: Sequence[Tick], robot: Robot, link: Link) -> list[ScheduledPacket]:
    """The dry run on ``link`` (``choreo.bus.transports.link(port)``): staged moves and STARTs
    where it can stage (``capabilities.staged_start``), else move frames, as the player sends
    them (``choreo.play.tick_sending``)."""
    if link.capabilities.staged_start:
        return packet_schedule(ticks, robot)
    return frame_schedule(ticks, robot, link.move_frame)
