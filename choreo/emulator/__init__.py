"""An emulated bus of LX serial servos, for users without hardware and for tests.

- :class:`BusEmulator`: servos on a wire with real timing (bytes in, replies out).
- :class:`EmulatedServo`: one servo's EEPROM, motion and faults (``emulator.servo(1)``).
- ``sim://`` URLs: call :func:`register_url_handler` once, then
  ``serial.serial_for_url("sim://?ids=1-6&clock=virtual")`` gives a :class:`SimSerial`.
- :class:`PtyBridge`: the emulator on a pseudo-terminal (``choreo emulate --pty PATH``).
"""

from __future__ import annotations

import serial

from .bus import (
    BusEmulator,
    ReceivedPacket,
    SentReply,
    ServoSpec,
    WireLog,
    parse_servo_specs,
)
from .protocol_sim import SimSerial, emulator_from_url
from .servo import Eeprom, EmulatedServo, ReplyFate, ReplyFaults, StartedMove

__all__ = [
    "BusEmulator",
    "EmulatedServo",
    "Eeprom",
    "StartedMove",
    "ReceivedPacket",
    "ReplyFate",
    "ReplyFaults",
    "SentReply",
    "ServoSpec",
    "SimSerial",
    "WireLog",
    "emulator_from_url",
    "parse_servo_specs",
    "register_url_handler",
]


def register_url_handler() -> None:
    """Let ``serial.serial_for_url`` open ``sim://`` URLs (idempotent)."""
    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
