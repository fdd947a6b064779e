"""The ``sim://`` pyserial URL handler: a serial port wired to a :class:`BusEmulator`.

``sim://?ids=1-6&model=LX-16A&echo=1&state=FILE&turnaround_ms=0.6&clock=real|virtual&seed=0
&start_gap_ms=0&board=rrc|lobot&physics=ROBOT&truth=FILE`` (all optional; ids like
``1-6,9,12-14``, a group may name its model: ``1-6,7:LX-224HV``; ``start_gap_ms`` > 0 is a fault:
a MOVE_START less than that after the servo's staged move is missed; ``board`` puts an emulated
controller board in front of the servos, and the port then talks that board's protocol at the
board's link speed: see ``choreo.emulator.boards``; ``physics`` puts the servos of a robot (its
name or robot.yaml) in front of its MuJoCo model, standing in its home pose and holding it
(``physics.py``; its clock is virtual unless ``clock=real``), ``truth`` names a servo figures
file saying how its servos really are, and ``stand=1`` holds a free-floating robot's body in the
air, its legs free, as on a stand). pyserial finds this module once
``choreo.emulator.register_url_handler()`` has run; tests can also wrap an existing emulator
with :meth:`SimSerial.from_emulator`.

Reads follow pyserial: ``read(n)`` returns ``n`` bytes, or fewer once ``timeout`` has passed
(``timeout=0``: what is there now; ``None``: wait for all ``n``). On a ``VirtualClock`` a read
advances the clock to exactly when the ``n``-th byte arrives, or by the whole timeout, so timeouts
cost no real time; ``write`` leaves the clock alone (a real write is buffered) and ``flush``
advances it to when the wire is free. On any other clock the port waits in real time. The baud
rate and other line settings are accepted and ignored: the emulated wire always runs at 115200
baud (an emulated board's link at the board's own speed).
``inter_byte_timeout`` is not supported (ignored).
"""

from __future__ import annotations

import math
import threading
import urllib.parse
from typing import Any

from serial import SerialBase, SerialException
from serial.serialutil import PortNotOpenError, to_bytes

from choreo.core.clock import RealClock, VirtualClock
from choreo.emulator.boards import BOARDS
from choreo.emulator.bus_emulator import (
    DEFAULT_START_GAP_S,
    DEFAULT_TURNAROUND_S,
    MAX_TURNAROUND_MS,
    BusEmulator,
    parse_servo_specs,
)
from choreo.emulator.physics import load_physics

URL_OPTIONS = (
    "ids",
    "model",
    "echo",
    "state",
    "turnaround_ms",
    "clock",
    "seed",
    "start_gap_ms",
    "board",
    "physics",
    "truth",
    "stand",
)


def emulator_from_url(url: str) -> BusEmulator:
    """Build the emulator a ``sim://`` URL describes; ``ValueError`` naming a bad option."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme.lower() != "sim":
        raise ValueError(f"expected a sim:// URL, got {url!r}")
    options = {}
    for name, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
        if name not in URL_OPTIONS:
            raise ValueError(f"unknown option {name!r}; valid options: {', '.join(URL_OPTIONS)}")
        options[name] = values[-1]
    # a world of physics runs in virtual time unless asked: as fast as it can be computed
    clock_name = options.get("clock", "virtual" if options.get("physics") else "real")
    if clock_name not in ("real", "virtual"):
        raise ValueError(f"clock must be real or virtual, got {clock_name!r}")
    echo = options.get("echo", "0")
    if echo not in ("0", "1"):
        raise ValueError(f"echo must be 0 or 1, got {echo!r}")
    board = options.get("board")
    if board is not None and board not in BOARDS:
        raise ValueError(f"board must be one of {', '.join(BOARDS)}, got {board!r}")
    if board is not None and echo == "1":
        raise ValueError("a board's link does not echo: leave out echo=1")
    clock = VirtualClock() if clock_name == "virtual" else RealClock()
    physics = None
    if options.get("physics"):
        for taken in ("ids", "model"):
            if taken in options:
                raise ValueError(
                    f"physics= puts the robot's own servos on the bus: leave out {taken}="
                )
        stand = options.get("stand", "0")
        if stand not in ("0", "1"):
            raise ValueError(f"stand must be 0 or 1, got {stand!r}")
        truth = options.get("truth") or None
        physics = load_physics(options["physics"], truth, clock, stand=stand == "1")
    else:
        for alone in ("truth", "stand"):
            if alone in options:
                raise ValueError(f"{alone}= goes with a robot's physics: name it with physics=")
    return (BOARDS[board] if board else BusEmulator)(
        parse_servo_specs(options.get("ids", "1-6")),
        model=options.get("model", "LX-16A"),
        clock=clock,
        physics=physics,
        turnaround_s=_ms(options, "turnaround_ms", DEFAULT_TURNAROUND_S, MAX_TURNAROUND_MS),
        echo=echo == "1",
        start_gap_s=_ms(options, "start_gap_ms", DEFAULT_START_GAP_S),
        seed=_integer(options, "seed", 0),
        state_path=options.get("state") or None,
    )


def _ms(options: dict[str, str], name: str, default_s: float, high_ms: float = math.inf) -> float:
    """The option ``name``, milliseconds from 0 to ``high_ms``, in seconds. Checked here, so a
    bad value is told as the URL writes it, not as the emulator's argument in seconds."""
    if name not in options:
        return default_s
    text = options[name]
    try:
        value_ms = float(text)
    except ValueError:
        value_ms = math.nan
    if not (math.isfinite(value_ms) and 0 <= value_ms <= high_ms):
        valid = f"from 0 to {high_ms:g}" if math.isfinite(high_ms) else ">= 0"
        raise ValueError(f"{name} must be a number of milliseconds {valid}, got {text!r}")
    return value_ms / 1000


def _integer(options: dict[str, str], name: str, default: int) -> int:
    text = options.get(name)
    if text is None:
        return default
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"{name} must be a whole number, got {text!r}") from None


class SimSerial(SerialBase):
    """A pyserial port on an emulated servo bus (``port.emulator``, ``port.clock``)."""

    is_open: bool  # SerialBase's (pyserial has no type hints)

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.emulator: BusEmulator | None = None
        self._given_emulator: BusEmulator | None = None
        self._wakeup = threading.Condition()
        self._read_cancelled = False
        super().__init__(*args, **kwargs)

    @classmethod
    def from_emulator(cls, emulator: BusEmulator, **settings) -> SimSerial:
        """An open port on an existing emulator; ``settings`` as for ``serial.Serial``
        (``timeout``...)."""
        port = cls(None, **settings)
        port._given_emulator = emulator
        port.port = "sim://"
        port.open()
        return port

    @property
    def clock(self):
        return self._open_emulator().clock

    # --- SerialBase ----------------------------------------------------------------------------
    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        if self._given_emulator is not None:
            self.emulator = self._given_emulator
        else:
            try:
                self.emulator = emulator_from_url(self._port)
            except ValueError as error:
                raise SerialException(str(error)) from error  # its words, without a hint
        self.is_open = True

    def close(self) -> None:
        # Not io.RawIOBase.close(): it would flush() a port that is already closed.
        if self.is_open:
            self._open_emulator().catch_up()  # what has crossed the wire by now has been acted on
            self.is_open = False
            with self._wakeup:
                self._wakeup.notify_all()

    def _reconfigure_port(self, *args, **kwargs) -> None:
        """Line settings don't matter to the emulated wire."""

    def _update_dtr_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass

    @property
    def in_waiting(self) -> int:
        return self._open_emulator().in_waiting

    @property
    def out_waiting(self) -> int:
        return self._open_emulator().out_waiting

    def write(self, data) -> int:
        data = to_bytes(data)
        self._open_emulator().write(data)
        with self._wakeup:
            self._wakeup.notify_all()
        return len(data)

    def flush(self) -> None:
        """Wait until the wire has sent everything; the servos have then acted on it."""
        emulator = self._open_emulator()
        emulator.clock.sleep_until(emulator.wire_free_s + emulator.drain_late_s)
        emulator.catch_up()

    def transmitter_empty(self) -> bool:
        """The UART's line-status bit (``TIOCSERGETLSR``): the last stop bit has left, exactly
        when it has, however late ``flush()`` would return."""
        emulator = self._open_emulator()
        return emulator.clock.now() >= emulator.wire_free_s

    def read(self, size: int = 1) -> bytes:
        emulator = self._open_emulator()
        if size <= 0:
            return b""
        deadline_s = emulator.clock.now() + (math.inf if self._timeout is None else self._timeout)
        if isinstance(emulator.clock, VirtualClock):  # move the clock instead of waiting
            return self._read_virtual(emulator, size, deadline_s)
        return self._read_real(emulator, size, deadline_s)

    def _read_virtual(self, emulator: BusEmulator, size: int, deadline_s: float) -> bytes:
        ready_s = emulator.run_until_received(size, deadline_s)
        if math.isinf(ready_s):
            raise SerialException(
                f"read({size}) with timeout=None would block forever: on a virtual clock only "
                f"{emulator.in_waiting} bytes will ever arrive; set a timeout"
            )
        emulator.clock.sleep_until(ready_s)
        return emulator.take_received(size)

    def _read_real(self, emulator: BusEmulator, size: int, deadline_s: float) -> bytes:
        data = bytearray()
        self._read_cancelled = False
        with self._wakeup:
            while True:
                data += emulator.take_received(size - len(data))
                now = emulator.clock.now()
                if (
                    len(data) >= size
                    or now >= deadline_s
                    or self._read_cancelled
                    or not self.is_open
                ):
                    return bytes(data)
                wake_s = min(deadline_s, emulator.next_event_s())
                self._wakeup.wait(None if math.isinf(wake_s) else wake_s - now)

    def cancel_read(self) -> None:
        with self._wakeup:
            self._read_cancelled = True
            self._wakeup.notify_all()

    def reset_input_buffer(self) -> None:
        self._open_emulator().discard_received()

    def reset_output_buffer(self) -> None:
        self._open_emulator().cancel_unsent()

    def _open_emulator(self) -> BusEmulator:
        if not self.is_open or self.emulator is None:
            raise PortNotOpenError()
        return self.emulator


Serial = SimSerial  # the name pyserial's serial_for_url looks for
