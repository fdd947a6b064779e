"""How an emulated servo's horn moves (uniform motion between two times) and how its potentiometer
reads it (one turn is 1500 counts, wrapped)."""

from __future__ import annotations

import math
from dataclasses import dataclass

UNITS_PER_TURN = 1500  # 1500 × 0.24° = 360°
READ_MIN_UNITS = -250  # readings wrap into READ_MIN_UNITS .. READ_MIN_UNITS + UNITS_PER_TURN - 1


@dataclass(frozen=True)
class Motion:
    """Uniform motion of the output from ``start_s`` until ``end_s`` (inf: keeps turning)."""

    start_s: float
    start_units: float
    velocity_units_s: float = 0.0
    end_s: float = -math.inf

    def output_at(self, time_s: float) -> float:
        moving_s = max(0.0, min(time_s, self.end_s) - self.start_s)
        return self.start_units + self.velocity_units_s * moving_s


def wrap_reading(units: float) -> float:
    """A position as the servo's potentiometer reads it: one turn is 1500 counts."""
    return (units - READ_MIN_UNITS) % UNITS_PER_TURN + READ_MIN_UNITS


def check_readable(pos_units: float) -> None:
    """Refuse a position the potentiometer cannot read (outside one turn)."""
    if not READ_MIN_UNITS <= pos_units < READ_MIN_UNITS + UNITS_PER_TURN:
        raise ValueError(
            f"pos_units must be in {READ_MIN_UNITS}..{READ_MIN_UNITS + UNITS_PER_TURN - 1} "
            f"(one turn of the potentiometer), got {pos_units}"
        )
