"""Faults injected into an emulated servo's replies (dropped, corrupted), and what became of each
reply sent."""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, replace


class ReplyFate(enum.Enum):
    SENT = "sent"
    DROPPED = "dropped"  # injected: never sent
    CORRUPTED = "corrupted"  # injected: one bit flipped
    COLLIDED = "collided"  # several servos answered at once


@dataclass(frozen=True)
class ReplyFaults:
    """Injected reply faults of one servo: the next N replies, or each with a probability."""

    drop_next: int = 0
    corrupt_next: int = 0
    drop_probability: float = 0.0
    corrupt_probability: float = 0.0

    def __post_init__(self) -> None:
        for name in ("drop_next", "corrupt_next"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("drop_probability", "corrupt_probability"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in 0..1, got {getattr(self, name)}")

    def take(self, draw: Callable[[], float]) -> tuple[ReplyFate, ReplyFaults]:
        """The fate of the reply being sent (SENT, DROPPED or CORRUPTED) and the faults left for
        the next ones; ``draw`` gives a uniform random number in [0, 1) from the bus's seeded
        generator."""
        if self.drop_next:
            return ReplyFate.DROPPED, replace(self, drop_next=self.drop_next - 1)
        if self.drop_probability and draw() < self.drop_probability:
            return ReplyFate.DROPPED, self
        if self.corrupt_next:
            return ReplyFate.CORRUPTED, replace(self, corrupt_next=self.corrupt_next - 1)
        if self.corrupt_probability and draw() < self.corrupt_probability:
            return ReplyFate.CORRUPTED, self
        return ReplyFate.SENT, self
