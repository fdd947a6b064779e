"""Running one joint's test moves on the bus and reading it as fast as the transport allows.

Between commands the servo's position is read back to back (one POS_READ after another: the
LX bus has no faster way), each read stamped at the middle of its request and reply, as BAM
stamps its reads; its supply and temperature are read every ``SLOW_READ_S``. A command is sent
at the first gap between reads after its time, and the time it was really sent is what the fit
uses.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from choreo.bus.servo_bus import ServoBus
from choreo.errors import BusError
from choreo.identify.joint_model import SentMove, Trial, Unload
from choreo.identify.moves import MovePlan
from choreo.robot.types import Joint

SLOW_READ_S = 0.5  # supply and temperature: they change slowly


@dataclass(frozen=True)
class Measured:
    """One joint's test on the bus: the trial, and the read rate, supply and temperature seen."""

    trial: Trial
    reads_per_s: float
    supply_v: tuple[float, ...]
    temp_c: tuple[float, ...]
    failed_reads: int


def run_moves(
    bus: ServoBus,
    joint: Joint,
    moves: MovePlan,
    start_setpoint_deg: float,
    on_progress: Callable[[float], None] | None = None,
) -> Measured:
    """Send ``moves`` to ``joint``'s servo on their times, reading it all along."""
    clock, servo = bus.clock, joint.servo_id
    start = clock.now()
    pending = list(moves.commands)
    sent: list[SentMove | Unload] = []
    read_s: list[float] = []
    read_deg: list[float] = []
    supply_v: list[float] = []
    temp_c: list[float] = []
    failed = 0
    next_slow_s = 0.0
    next_progress_s = 0.0
    while True:
        now = clock.now() - start
        while pending and pending[0].at_s <= now:
            command = pending.pop(0)
            sent.append(_send(bus, joint, command, clock.now() - start))
        if now >= moves.duration_s:
            break
        if now >= next_slow_s:
            try:
                supply_v.append(bus.read_vin(servo) / 1000)
                temp_c.append(float(bus.read_temperature(servo)))
            except BusError:
                failed += 1
            next_slow_s = now + SLOW_READ_S
            continue
        if on_progress is not None and now >= next_progress_s:
            on_progress(min(now / moves.duration_s, 1.0))
            next_progress_s = now + 0.1
        before = clock.now()
        try:
            position = bus.read_position(servo)
        except BusError:
            failed += 1
            continue
        after = clock.now()
        read_s.append((before + after) / 2 - start)
        read_deg.append(joint.to_deg(position))
    elapsed = clock.now() - start
    return Measured(
        Trial(tuple(sent), np.array(read_s), np.array(read_deg), start_setpoint_deg),
        len(read_s) / elapsed if elapsed > 0 else 0.0,
        tuple(supply_v),
        tuple(temp_c),
        failed,
    )


def _send(
    bus: ServoBus, joint: Joint, command: SentMove | Unload, at_s: float
) -> SentMove | Unload:
    if isinstance(command, Unload):
        bus.unload(joint.servo_id)
        return Unload(at_s)
    pos_units = round(joint.to_units(command.target_deg))
    bus.move(joint.servo_id, pos_units, round(command.time_s * 1000))
    # what the servo was really asked: the angle of the whole position unit sent
    return SentMove(at_s, joint.to_deg(pos_units), round(command.time_s * 1000) / 1000)
