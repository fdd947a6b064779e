"""How a tick reaches the servos, chosen once per play from the transport's capabilities.

- :class:`StagedStart` (the raw bus): each servo whose target changes is staged
  (MOVE_TIME_WAIT_WRITE, every servo of the tick in one write) while the tick before runs, then
  one broadcast MOVE_START at the tick's deadline starts every servo at the same instant.
- :class:`MoveFrames` (a controller board that cannot stage: the RRC and LOBOT boards): the tick
  goes out as one multi-servo move frame with the tick's duration (a tick's moves share one).
  The board forwards it one servo at a time, so the frame is sent early enough for those starts
  to be centred on the deadline, and the report gives the first-to-last start skew.

Both answer the same questions for the player's deadline loop (``choreo.play.stream``): how long
before a deadline to send, when the link is free again, and what sending costs the bus.
"""

from __future__ import annotations

import abc
from collections.abc import Iterator

from choreo.bus.protocol import BROADCAST_ID, BYTE_TIME_S
from choreo.bus.servo_bus import ServoBus
from choreo.plan.ticks import MOVE_BYTES, START_BYTES, Tick
from choreo.robot.types import Joint, Robot

Moves = list[tuple[int, int]]  # (servo_id, pos_units)


def staged_moves(
    tick: Tick, robot: Robot, *, all_servos: bool = False
) -> Iterator[tuple[Joint, int, int]]:
    """(joint, pos_units, time_ms) for each servo that must be staged for ``tick``."""
    for joint, target, staged in zip(robot.joints, tick.targets_units, tick.staged):
        if staged or all_servos:
            yield joint, target, tick.duration_ms


class TickSending(abc.ABC):
    """One way of sending ticks to the servos of ``robot`` on ``bus``."""

    read_link_s = 0.0  # link time a health read takes besides its own wait

    def __init__(self, bus: ServoBus, robot: Robot):
        self.bus, self.robot = bus, robot
        self.servos = len(robot.joints)

    def moves(self, tick: Tick, *, all_servos: bool) -> Moves:
        """(servo_id, pos_units) of each servo ``tick`` moves (every servo: ``all_servos``)."""
        robot = self.robot
        return [(j.servo_id, pos) for j, pos, _ in staged_moves(tick, robot, all_servos=all_servos)]

    @abc.abstractmethod
    def first_lead_s(self) -> float:
        """From now until the first tick can start on every servo."""

    @abc.abstractmethod
    def restage_s(self) -> float:
        """From now until every servo has a new tick (the player fell behind)."""

    @abc.abstractmethod
    def start_lead_s(self, servos: int) -> float:
        """How long before a tick's deadline its start is sent, for ``servos`` moving."""

    @abc.abstractmethod
    def link_free_s(self, now_s: float, wire_free_s: float) -> float:
        """When the next bytes can leave, with the bytes sent so far on the wire until
        ``wire_free_s``."""

    @abc.abstractmethod
    def stage(self, tick: Tick, *, all_servos: bool) -> int:
        """Whatever goes out ahead of ``tick``'s deadline; the bytes sent."""

    @abc.abstractmethod
    def start(self, tick: Tick, moves: Moves) -> tuple[int, float | None]:
        """Start ``tick`` (``moves``: what it moves); the bytes sent, and how long they keep the
        link busy (None: their time on the servos' wire)."""

    @abc.abstractmethod
    def start_skew_ms(self) -> float:
        """First-to-last start of a tick's moves, the widest this play sent."""


class StagedStart(TickSending):
    """Staged moves, then one broadcast MOVE_START at each deadline."""

    def __init__(self, bus: ServoBus, robot: Robot):
        super().__init__(bus, robot)
        self._stage_all_s = self.servos * MOVE_BYTES * BYTE_TIME_S
        self._start_lead_s = START_BYTES * BYTE_TIME_S

    def first_lead_s(self) -> float:
        return self._stage_all_s

    def restage_s(self) -> float:
        return self._stage_all_s

    def start_lead_s(self, servos: int) -> float:
        return self._start_lead_s

    def link_free_s(self, now_s: float, wire_free_s: float) -> float:
        return now_s  # a START never waits: the staging before it was timed to be over

    def stage(self, tick: Tick, *, all_servos: bool) -> int:
        """Every staged move of ``tick`` in one write: one system call instead of one per servo,
        and behind GPIO direction lines one wait for the wire instead of one per servo."""
        moves = self.moves(tick, all_servos=all_servos)
        return self.bus.stage_many(moves, tick.duration_ms) if moves else 0

    def start(self, tick: Tick, moves: Moves) -> tuple[int, float | None]:
        self.bus.start(BROADCAST_ID)
        return START_BYTES, None

    def start_skew_ms(self) -> float:
        return 0.0


class MoveFrames(TickSending):
    """One move frame per tick, sent so that the board's starts are centred on the deadline."""

    def __init__(self, bus: ServoBus, robot: Robot):
        super().__init__(bus, robot)
        self.capabilities = bus.capabilities
        # A read's request and reply cross the board's link too (~16 bytes; 17 ms at 9600 baud).
        self.read_link_s = 16 * self.capabilities.host_byte_time_s
        self.most_moved = 0  # servos in the largest move frame (for the start skew)

    def frame_lead_s(self, servos: int) -> float:
        """From sending a move frame until its first servo starts moving."""
        cap = self.capabilities
        frame_bytes = cap.move_frame_bytes + 3 * servos
        return frame_bytes * cap.host_byte_time_s + cap.forward_s_per_servo

    def frame_busy_s(self, frame_bytes: int, servos: int) -> float:
        """How long a move frame keeps the board's link and servo bus busy."""
        cap = self.capabilities
        return frame_bytes * cap.host_byte_time_s + servos * cap.forward_s_per_servo

    def first_lead_s(self) -> float:
        return self.start_lead_s(self.servos)

    def restage_s(self) -> float:
        return self.frame_lead_s(self.servos)

    def start_lead_s(self, servos: int) -> float:
        return self.frame_lead_s(servos) + self.capabilities.start_skew_s(servos) / 2

    def link_free_s(self, now_s: float, wire_free_s: float) -> float:
        return max(now_s, wire_free_s)  # a frame waits for the frames before it to leave

    def stage(self, tick: Tick, *, all_servos: bool) -> int:
        return 0  # the move frame at the tick's deadline carries its targets

    def start(self, tick: Tick, moves: Moves) -> tuple[int, float | None]:
        sent = self.bus.move_many(moves, tick.duration_ms)
        self.most_moved = max(self.most_moved, len(moves))
        return sent, self.frame_busy_s(sent, len(moves))

    def start_skew_ms(self) -> float:
        return self.capabilities.start_skew_s(self.most_moved) * 1000


def tick_sending(bus: ServoBus, robot: Robot) -> TickSending:
    """The way this transport can send ticks (``capabilities.staged_start``)."""
    kind = StagedStart if bus.capabilities.staged_start else MoveFrames
    return kind(bus, robot)
