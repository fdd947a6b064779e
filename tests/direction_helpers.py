"""A bus behind emulated direction lines, as on a Pi's UART with GPIO direction pins."""

from __future__ import annotations

from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports.direction import (
    DirectionSerial,
)
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial
from choreo.emulator.direction_gate import FakeDirectionLines


def gated_bus(serial_class=DirectionSerial, *, echo: bool = False, drain_late_s: float = 0.0):
    emulator = BusEmulator(range(1, 4), clock=VirtualClock(), echo=echo)
    lines = FakeDirectionLines(emulator, drain_late_s=drain_late_s)
    sim = SimSerial.from_emulator(emulator, timeout=0.05, baudrate=115200)
    port = serial_class(sim, lines)
    return ServoBus(port, retries=0, echo="none"), emulator, lines


class NoDrain(DirectionSerial):
    """Switches to receive as soon as write() returns, before the bytes have left."""

    def write(self, data):
        self.lines.transmit()
        written = self._port.write(data)
        self.lines.receive()
        return written


class ListensLate(DirectionSerial):
    """Drains, but keeps transmitting until after the reply has come (never opens receive)."""

    def write(self, data):
        self.lines.transmit()
        written = self._port.write(data)
        self._port.flush()
        return written


class TurnsOnDrain(DirectionSerial):
    """Waits on flush() (tcdrain) to turn the line around, as choreo did before."""

    def write(self, data):
        self.lines.transmit()
        try:
            written = self._port.write(data)
            self._port.flush()
        finally:
            self.lines.receive()
        return written


LATE_DRAINS_S = [0.0, 0.0005, 0.001, 0.004, 0.010]  # Linux: one jiffy or more (HZ=1000..100)
