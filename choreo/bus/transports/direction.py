"""GPIO half-duplex direction control: the raw LX bus on a Raspberry Pi / Jetson UART.

The robots' HATs gate the one-wire bus with two enable lines: TX_CON lets the UART drive the
bus, RX_CON lets the bus reach the UART's receiver. :class:`DirectionSerial` wraps the UART so
the bus is driven only while a write leaves: transmit on, write, wait until the UART's output has
drained (tcdrain), then receive on. The bus idles in receive, so a servo's reply is never cut
off, and no echo comes back (the receiver is off while transmitting).

``--direction`` / robot.yaml ``bus: direction:`` takes a preset name or explicit lines,
``rx=4,tx=27[,chip=/dev/gpiochip0]``. Pin numbers are GPIO line offsets on the chip, which on a
Raspberry Pi's ``gpiochip0`` are the BCM numbers. The ``gpiod`` package (libgpiod 2) is
imported only here, only when direction control is asked for: ``pip install 'choreo[pi]'``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from choreo.errors import ChoreoError

DEFAULT_CHIP = "/dev/gpiochip0"


@dataclass(frozen=True)
class DirectionPins:
    rx: int  # RX_CON: high lets the bus reach the UART's receiver
    tx: int  # TX_CON: high lets the UART drive the bus
    chip: str = DEFAULT_CHIP


# BCM numbers from the vendors' SDK constants (their comments disagree; the constants are used).
PRESETS = {
    "tonypi": DirectionPins(rx=4, tx=27),  # Pi 4 HAT: BOARD 7 / BOARD 13
    "spiderpi": DirectionPins(rx=4, tx=27),
    "armpi-pro": DirectionPins(rx=4, tx=27),
    "jethexa": DirectionPins(rx=17, tx=27),  # on a Jetson give chip= and the lines' offsets
    "ainex": DirectionPins(rx=19, tx=26),
}


def parse_direction(text: str) -> DirectionPins:
    """A preset name or ``rx=N,tx=N[,chip=PATH]``; ``ValueError`` saying what is valid."""
    if text in PRESETS:
        return PRESETS[text]
    valid = f"a preset ({', '.join(PRESETS)}) or rx=N,tx=N[,chip=PATH], e.g. rx=4,tx=27"
    try:
        values = dict(item.split("=", 1) for item in text.split(","))
        if set(values) - {"rx", "tx", "chip"} or not {"rx", "tx"} <= set(values):
            raise ValueError
        pins = DirectionPins(int(values["rx"]), int(values["tx"]), values.get("chip", DEFAULT_CHIP))
    except ValueError:
        raise ValueError(f"bad direction {text!r}: expected {valid}") from None
    if pins.rx == pins.tx or min(pins.rx, pins.tx) < 0:
        raise ValueError(f"bad direction {text!r}: rx and tx are two different lines >= 0")
    return pins


class DirectionLines(Protocol):
    def transmit(self) -> None:
        """Drive the bus: TX_CON high, RX_CON low."""

    def receive(self) -> None:
        """Listen to the bus: TX_CON low, RX_CON high."""

    def close(self) -> None: ...


class GpiodLines:
    """The two enable lines through libgpiod 2 (``gpiod``)."""

    def __init__(self, pins: DirectionPins):
        try:
            import gpiod
            from gpiod.line import Direction, Value
        except ImportError:
            raise ChoreoError(
                "GPIO direction control needs the gpiod package (libgpiod 2): "
                "pip install 'choreo[pi]'"
            ) from None
        self.pins, self._value = pins, Value
        try:
            self._request = gpiod.request_lines(
                pins.chip,
                consumer="choreo",
                config={
                    (pins.rx, pins.tx): gpiod.LineSettings(
                        direction=Direction.OUTPUT, output_value=Value.INACTIVE
                    )
                },
            )
        except OSError as error:
            raise ChoreoError(
                f"cannot use GPIO lines rx={pins.rx}, tx={pins.tx} on {pins.chip}: {error}; "
                "is another program using them, and may you open the chip (group gpio)?"
            ) from error
        self.receive()

    def _set(self, rx: bool, tx: bool) -> None:
        on, off = self._value.ACTIVE, self._value.INACTIVE
        # Both changes in one call: the two lines never drive and listen at once.
        self._request.set_values({self.pins.rx: on if rx else off, self.pins.tx: on if tx else off})

    def transmit(self) -> None:
        self._set(rx=False, tx=True)

    def receive(self) -> None:
        self._set(rx=True, tx=False)

    def close(self) -> None:
        self._request.release()


def direction_lines(direction) -> DirectionLines:
    """Lines from a preset name, ``rx=..,tx=..`` text, :class:`DirectionPins`, or lines as they
    are (a test's fake)."""
    if isinstance(direction, str):
        try:
            direction = parse_direction(direction)
        except ValueError as error:
            raise ChoreoError(str(error)) from None
    if isinstance(direction, DirectionPins):
        return GpiodLines(direction)
    return direction


class DirectionSerial:
    """A UART whose writes drive the bus only while they leave; everything else passes through."""

    def __init__(self, port, lines: DirectionLines):
        self._port, self.lines = port, lines
        lines.receive()

    def __getattr__(self, name):
        return getattr(self._port, name)

    @property
    def timeout(self):
        return self._port.timeout

    @timeout.setter
    def timeout(self, value) -> None:
        self._port.timeout = value

    def write(self, data: bytes) -> int:
        self.lines.transmit()
        try:
            written = self._port.write(data)
            self._port.flush()  # write() returns before the bytes leave: drain first
        finally:
            self.lines.receive()
        return written

    def close(self) -> None:
        try:
            self._port.close()
        finally:
            self.lines.close()
