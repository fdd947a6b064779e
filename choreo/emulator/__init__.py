"""An emulated bus of LX serial servos, for users without hardware and for tests.

- :class:`BusEmulator`: servos on a wire with real timing (bytes in, replies out).
- :class:`EmulatedServo`: one servo's state, motion and faults (``emulator.servo(1)``);
  ``servo_commands``: its answer to each command; ``eeprom``: what it keeps across power-off;
  ``servo_motion``: how its horn moves and reads; ``reply_faults``: faults injected into replies.
- ``sim://`` URLs: call :func:`register_url_handler` once, then
  ``serial.serial_for_url("sim://?ids=1-6&clock=virtual")`` gives a :class:`SimSerial`.
- :class:`PtyBridge`: the emulator on a pseudo-terminal (``choreo emulate --pty PATH``).
- ``boards``: the RRC board and the LOBOT controller in front of the servos
  (``sim://?board=rrc``, ``choreo emulate --board lobot``); ``direction_gate``: fake GPIO direction
  lines for tests.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from choreo.emulator.backend import connection, register_url_handler  # noqa: I001 (after the above)
from choreo.emulator.bus_emulator import (
    BusEmulator,
    ReceivedPacket,
    SentReply,
    ServoSpec,
    WireLog,
    parse_servo_specs,
)
from choreo.emulator.eeprom import Eeprom
from choreo.emulator.emulated_servo import EmulatedServo, StartedMove
from choreo.emulator.protocol_sim import SimSerial, emulator_from_url
from choreo.emulator.reply_faults import ReplyFate, ReplyFaults

if TYPE_CHECKING:  # mypy checks that sim:// keeps the contract every backend keeps
    from choreo.bus.transports import Transport
    from choreo.emulator import backend

    _SIM_KEEPS_IT: Transport = backend

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
    "connection",
    "register_url_handler",
]
