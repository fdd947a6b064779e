"""What happened on the emulated wire, read back: ``WireTrace.of(emulator)`` is the one reader
of the emulator's wire log outside the emulator (a copy taken at once: the emulator keeps
logging), and the rest of this module reads the copy: when the STARTs and the last STOP reached
the servos, where the servos really went (servo IDs and units only: ``choreo.play.path_errors``
reads them through a robot's joints) and how far apart one tick's moves began."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from choreo.bus.protocol import Command
from choreo.emulator.bus_emulator import BusEmulator, ReceivedPacket
from choreo.emulator.emulated_servo import StartedMove

START_SLACK_S = 0.0005  # a START's moves begin up to this long before the instant asked


@dataclass(frozen=True)
class WireTrace:
    """The packets the servos received and the moves they began, oldest first."""

    packets: tuple[ReceivedPacket, ...]
    moves: tuple[StartedMove, ...]

    @staticmethod
    def of(emulator: BusEmulator) -> WireTrace:
        """The emulator's wire log up to now (as long as its ``log_limit`` keeps)."""
        log = emulator.log
        return WireTrace(tuple(log.packets), tuple(log.moves))

    def start_times_s(self, since_s: float) -> list[float]:
        """When each MOVE_START began the servos' moves (once per START), from ``since_s`` on."""
        return sorted(
            {
                m.time_s
                for m in self.moves
                if m.command is Command.MOVE_START and m.time_s >= since_s - START_SLACK_S
            }
        )

    def last_stop_s(self, since_s: float) -> float | None:
        """When the last MOVE_STOP from ``since_s`` on reached the servos."""
        stops = [
            p.time_s
            for p in self.packets
            if p.packet.command == Command.MOVE_STOP and p.time_s >= since_s
        ]
        return max(stops, default=None)


def executed_units(
    moves: Iterable[StartedMove], servo_id: int, start_units: float, times_s: np.ndarray
) -> np.ndarray:
    """Position (POS_READ units) of one servo at ``times_s``, from its logged linear moves.

    A move runs from ``from_units`` to ``to_units`` over ``duration_s``; a later move starts from
    wherever the servo then is (the log records that), so the path is piecewise linear.
    """
    own = sorted((m for m in moves if m.servo_id == servo_id), key=lambda m: m.time_s)
    times_s = np.asarray(times_s, dtype=float)
    if not own:
        return np.full(times_s.shape, float(start_units))
    starts = np.array([m.time_s for m in own])
    index = np.searchsorted(starts, times_s, side="right") - 1
    before = index < 0
    index = np.clip(index, 0, None)
    begin = np.array([m.from_units for m in own])[index]
    end = np.array([m.to_units for m in own])[index]
    duration = np.array([m.duration_s for m in own])[index]
    fraction = np.where(
        duration > 0, (times_s - starts[index]) / np.where(duration > 0, duration, 1), 1.0
    )
    path = begin + (end - begin) * np.clip(fraction, 0.0, 1.0)
    return np.where(before, float(start_units), path)


def start_skew_ms(
    moves: Iterable[StartedMove],
    since_s: float = -math.inf,
    until_s: float = math.inf,
    group_gap_s: float = 0.005,
) -> float:
    """The largest first-to-last spread of move starts within one burst (starts less than
    ``group_gap_s`` after the previous one), between ``since_s`` and ``until_s``: 0 when every
    tick starts all its servos at once, the forwarding time when they start one after another."""
    times = sorted(m.time_s for m in moves if since_s <= m.time_s <= until_s)
    skew_s, group_start_s, last_s = 0.0, -math.inf, -math.inf
    for time_s in times:
        if time_s - last_s > group_gap_s:
            group_start_s = time_s
        skew_s = max(skew_s, time_s - group_start_s)
        last_s = time_s
    return skew_s * 1000
