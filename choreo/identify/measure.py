"""Running one joint's test moves on the bus and reading it as fast as the transport allows.

Between commands the servo's position is read back to back (one POS_READ after another: the
LX bus has no faster way), each read stamped at the middle of its request and reply, as BAM
stamps its reads. Its neighbours in the chain, which yield under its torque, are read in turn
with it (each one every fourth read, the joint the rest: half the rate with two neighbours,
three quarters with one); its supply and temperature are read every ``SLOW_READ_S``. A command
is sent at the first gap between reads after its time, and the time it was really sent is what
the fit uses.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from choreo.bus.servo_bus import ServoBus
from choreo.errors import BusError
from choreo.identify.joint_model import SentMove, SupplyReads, Trial, Unload
from choreo.identify.moves import MovePlan
from choreo.identify.neighbours import NeighbourReads
from choreo.robot.types import Joint

SLOW_READ_S = 0.5  # supply and temperature: they change slowly


@dataclass(frozen=True)
class Measured:
    """One joint's test on the bus: the trial, and the read rate (every position read, the
    neighbours' too), supply and temperature seen."""

    trial: Trial
    reads_per_s: float
    supply_v: tuple[float, ...]
    temp_c: tuple[float, ...]
    failed_reads: int


@dataclass(frozen=True)
class Neighbour:
    """A joint read along with the tested one, and where it was told to hold (degrees)."""

    joint: Joint
    held_deg: float


class _Reads:
    """The position reads taken in turn: each neighbour every fourth read (~140 reads/s, as
    often as the fit's smoothing of their reads uses), the tested joint the rest (joint, first
    neighbour, joint, second neighbour or the joint again)."""

    def __init__(self, joint: Joint, neighbours: Sequence[Neighbour]):
        if len(neighbours) > 2:  # the load names two at most (joint_load.MAX_NEIGHBOURS)
            raise ValueError(f"{joint.name}: two neighbours at most, not {len(neighbours)}")
        others = [n.joint for n in neighbours] + [joint]
        self.turns = [joint, others[0], joint, others[1]] if neighbours else [joint]
        self.times: dict[str, list[float]] = {j.name: [] for j in self.turns}
        self.angles: dict[str, list[float]] = {j.name: [] for j in self.turns}
        self.turn = 0

    def take(self, bus: ServoBus, start_s: float) -> None:
        """The next servo's position, stamped at the middle of the exchange."""
        joint = self.turns[self.turn]
        self.turn = (self.turn + 1) % len(self.turns)
        before = bus.clock.now()
        position = bus.read_position(joint.servo_id)
        self.times[joint.name].append((before + bus.clock.now()) / 2 - start_s)
        self.angles[joint.name].append(joint.to_deg(position))

    def of(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.times[name]), np.array(self.angles[name])

    @property
    def count(self) -> int:
        return sum(len(times) for times in self.times.values())


def run_moves(
    bus: ServoBus,
    joint: Joint,
    moves: MovePlan,
    start_setpoint_deg: float,
    on_progress: Callable[[float], None] | None = None,
    neighbours: Sequence[Neighbour] = (),
) -> Measured:
    """Send ``moves`` to ``joint``'s servo on their times, reading it all along, and its
    ``neighbours`` in turn with it."""
    clock, servo = bus.clock, joint.servo_id
    start = clock.now()
    pending = list(moves.commands)
    sent: list[SentMove | Unload] = []
    reads = _Reads(joint, neighbours)
    supply_v: list[float] = []
    supply_s: list[float] = []  # when each was read (the fit sets the sag against the load)
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
                before = clock.now()
                supply_v.append(bus.read_vin(servo) / 1000)
                supply_s.append((before + clock.now()) / 2 - start)
                temp_c.append(float(bus.read_temperature(servo)))
            except BusError:
                failed += 1
            next_slow_s = now + SLOW_READ_S
            continue
        if on_progress is not None and now >= next_progress_s:
            on_progress(min(now / moves.duration_s, 1.0))
            next_progress_s = now + 0.1
        try:
            reads.take(bus, start)
        except BusError:
            failed += 1
    elapsed = clock.now() - start
    nearby = tuple(
        NeighbourReads(n.joint.name, *reads.of(n.joint.name), n.held_deg) for n in neighbours
    )
    return Measured(
        Trial(
            tuple(sent),
            *reads.of(joint.name),
            start_setpoint_deg,
            nearby,
            SupplyReads(np.array(supply_s), np.array(supply_v)),
        ),
        reads.count / elapsed if elapsed > 0 else 0.0,
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
