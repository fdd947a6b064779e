"""Fake GPIO direction lines for tests: the HAT's TX_CON / RX_CON enables in front of an
emulated bus, as strict as the real gate.

A host byte reaches the servos only if transmit was on for the whole time it crossed the wire; a
byte for the host (a reply, an echo) reaches it only if receive was on for the whole time. So a
driver that switches to receive before its request has left (no drain), or listens too late,
loses bytes and its reads time out, as on the robot. ``drain_late_s`` makes the port's
``flush()`` (tcdrain) return that long after the last byte has left, as Linux's does.
"""

from __future__ import annotations

import bisect
import math

from choreo.emulator.bus_emulator import BusEmulator


class FakeDirectionLines:
    """Installs itself as ``emulator.direction``; both lines start off. ``changes`` lists
    (time_s, tx_on, rx_on) in order, for tests of the toggle order."""

    def __init__(self, emulator: BusEmulator, drain_late_s: float = 0.0):
        self.emulator = emulator
        emulator.drain_late_s = drain_late_s
        self.changes: list[tuple[float, bool, bool]] = [(-math.inf, False, False)]
        emulator.direction = self

    def transmit(self) -> None:
        self._set(tx=True, rx=False)

    def receive(self) -> None:
        self._set(tx=False, rx=True)

    def close(self) -> None:
        self._set(tx=False, rx=False)

    def _set(self, *, tx: bool, rx: bool) -> None:
        clock = self.emulator.clock
        self.changes.append((max(clock.now(), self.changes[-1][0]), tx, rx))

    def open_throughout(self, start_s: float, end_s: float, line: str) -> bool:
        """Whether ``line`` ("tx" or "rx") was on from ``start_s`` until ``end_s``."""
        column = 1 if line == "tx" else 2
        times = [c[0] for c in self.changes]
        first = bisect.bisect_right(times, start_s) - 1
        last = bisect.bisect_left(times, end_s)  # changes strictly inside the byte count
        return all(change[column] for change in self.changes[first:last])
