"""GPIO half-duplex direction control: the raw LX bus on a Raspberry Pi / Jetson UART.

The robots' HATs gate the one-wire bus with two enable lines: TX_CON lets the UART drive the
bus, RX_CON lets the bus reach the UART's receiver. :class:`DirectionSerial` wraps the UART so
the bus is driven only while a write leaves: transmit on, write, wait until the last stop bit has
left, then receive on. The bus idles in receive, so a servo's reply is never cut off, and no echo
comes back (the receiver is off while transmitting).

The wait is not ``flush()`` (tcdrain): Linux's serial core polls the transmitter with ``msleep``
of at least one jiffy (4-8 ms at HZ=250), while a servo answers ~0.6 ms after the request. So the
end of the write is computed from the bytes and the baud rate (plus a small margin) and, where
the UART reports it, confirmed by the line-status register's transmitter-empty bit
(``TIOCSERGETLSR``), polled without sleeping a jiffy.

``--direction`` / robot.yaml ``bus: direction:`` takes a preset name or explicit lines,
``rx=4,tx=27[,chip=/dev/gpiochip0]``. Pin numbers are GPIO line offsets on the chip (a path, or
a chip label such as ``tegra-gpio``), which on a Raspberry Pi's ``gpiochip0`` are the BCM
numbers. The presets are BCM numbers; on a Jetson they are resolved to its chip and lines per
model (``jetson.py``), or refused naming the header pins to look up. The ``gpiod`` package
(libgpiod 2) is imported only here, only when direction control is asked for:
``pip install 'choreo[pi]'``.
"""

from __future__ import annotations

import fcntl
import struct
import termios
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from choreo.bus.transports import jetson
from choreo.core.arguments import shown
from choreo.core.clock import Clock, RealClock
from choreo.errors import ChoreoError, OptionError

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
    "jethexa": DirectionPins(rx=17, tx=27),  # a Jetson: resolved per model (jetson.py)
    "ainex": DirectionPins(rx=19, tx=26),
}


def parse_direction(text: str) -> DirectionPins:
    """A preset name or ``rx=N,tx=N[,chip=PATH]``; ``ValueError`` saying what is valid."""
    if text in PRESETS:
        return PRESETS[text]
    valid = f"a preset ({', '.join(PRESETS)}) nor rx=N,tx=N[,chip=PATH], e.g. rx=4,tx=27"
    try:
        values = dict(item.split("=", 1) for item in text.split(","))
        if set(values) - {"rx", "tx", "chip"} or not {"rx", "tx"} <= set(values):
            raise ValueError
        pins = DirectionPins(int(values["rx"]), int(values["tx"]), values.get("chip", DEFAULT_CHIP))
    except ValueError:
        raise ValueError(f"{text!r} is not {valid}") from None
    if pins.rx == pins.tx or min(pins.rx, pins.tx) < 0:
        raise ValueError(f"{text!r}: rx and tx must be two different lines >= 0")
    return pins


class DirectionLines(Protocol):
    def transmit(self) -> None:
        """Drive the bus: TX_CON high, RX_CON low."""

    def receive(self) -> None:
        """Listen to the bus: TX_CON low, RX_CON high."""

    def close(self) -> None: ...


def chip_path(gpiod, chip: str) -> str:
    """A chip's device path: ``chip`` itself, or the /dev/gpiochip* whose label it is."""
    if chip.startswith("/"):
        return chip
    for path in sorted(Path("/dev").glob("gpiochip*")):
        try:
            with gpiod.Chip(str(path)) as found:
                if found.get_info().label == chip:
                    return str(path)
        except OSError:
            continue
    raise ChoreoError(
        f"no GPIO chip labelled {chip!r} (list them with `gpiodetect`); pass chip=/dev/gpiochipN"
    )


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
                chip_path(gpiod, pins.chip),
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


def direction_lines(direction, compatibles: list[str] | None = None) -> DirectionLines:
    """Lines from a preset name, ``rx=..,tx=..`` text, :class:`DirectionPins`, or lines as they
    are (a test's fake). ``compatibles``: the device tree's (read from the system if None)."""
    if isinstance(direction, str):
        direction = board_pins(direction, compatibles)
    if isinstance(direction, DirectionPins):
        return GpiodLines(direction)
    if not all(callable(getattr(direction, name, None)) for name in ("transmit", "receive")):
        raise OptionError(
            "direction",
            f"must be a preset ({', '.join(PRESETS)}), 'rx=N,tx=N[,chip=PATH]' or "
            f"DirectionPins, got {shown(direction)}",
        )
    return direction


def board_pins(text: str, compatibles: list[str] | None = None) -> DirectionPins:
    """The lines ``--direction TEXT`` means on this computer: a preset's BCM numbers resolved
    on a Jetson (``ChoreoError`` where they cannot be), anything else as written."""
    try:
        pins = parse_direction(text)
    except ValueError as error:
        raise OptionError("direction", str(error)) from None
    if text not in PRESETS:
        return pins
    if compatibles is None:
        compatibles = jetson.read_compatibles()
    lines = jetson.resolve_preset(text, pins.rx, pins.tx, compatibles)
    return pins if lines is None else DirectionPins(*lines)


BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit
# After the computed end: the UART starts sending a moment after write() returns. Well below a
# servo's ~0.6 ms turnaround, so receive is on before the first reply byte.
TURNAROUND_MARGIN_S = 0.00005
CONFIRM_POLL_S = 0.00002  # spin step while the transmitter-empty bit is not yet set
# While the bit says bytes are still leaving, switching would cut them off (a lost move), so it
# is waited for; this only bounds the wait for a bit that never comes (a driver that lies).
CONFIRM_LIMIT_S = 0.002
TIOCSERGETLSR = getattr(termios, "TIOCSERGETLSR", 0x5459)  # Linux; absent from some Pythons
TIOCSER_TEMT = 0x01


def transmitter_empty(port) -> bool | None:
    """Whether the UART has sent its last stop bit, from its line-status register; None where it
    cannot say (not a tty, or a driver without ``TIOCSERGETLSR``, as many USB adapters)."""
    ask = getattr(port, "transmitter_empty", None)  # the emulator answers for its wire
    if ask is not None:
        return ask()
    try:
        status = fcntl.ioctl(port.fileno(), TIOCSERGETLSR, struct.pack("I", 0))
    except (AttributeError, OSError, ValueError):
        return None
    return bool(struct.unpack("I", status)[0] & TIOCSER_TEMT)


class DirectionSerial:
    """A UART whose writes drive the bus only while they leave; everything else passes through.

    Each ``write`` returns once its bytes have left, so ``flush`` has nothing to wait for."""

    def __init__(self, port, lines: DirectionLines, clock: Clock | None = None):
        self._port, self.lines = port, lines
        self.clock = clock or getattr(port, "clock", None) or RealClock(spin_s=0.002)
        self.has_status_register = transmitter_empty(port) is not None
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
            started_s = self.clock.now()
            written = self._port.write(data)
            self._wait_until_sent(started_s, len(data))
        finally:
            self.lines.receive()
        return written

    def flush(self) -> None:
        """Nothing to wait for: every write has left before it returned (and tcdrain would
        sleep a jiffy)."""

    def wire_time_s(self, byte_count: int) -> float:
        """How long ``byte_count`` bytes take on the wire at the port's baud rate."""
        return byte_count * BITS_PER_BYTE / self._port.baudrate

    def _wait_until_sent(self, started_s: float, byte_count: int) -> None:
        """Until the last stop bit has left: the computed end, then (where the UART can say so)
        its transmitter-empty bit, spun on for at most ``CONFIRM_LIMIT_S``."""
        sent_s = started_s + self.wire_time_s(byte_count) + TURNAROUND_MARGIN_S
        self.clock.sleep_until(sent_s)
        if not self.has_status_register:
            return
        give_up_s = self.clock.now() + CONFIRM_LIMIT_S
        while not transmitter_empty(self._port) and self.clock.now() < give_up_s:
            self.clock.sleep_until(self.clock.now() + CONFIRM_POLL_S)

    def close(self) -> None:
        try:
            self._port.close()
        finally:
            self.lines.close()
