"""The emulator as a transport backend (``sim://`` in :data:`choreo.bus.transports.BACKENDS`):
the host talks to the emulated servos as it would to real ones, on the raw LX bus or through the
emulated board the URL names (``sim://?board=rrc``), and the bus keeps time on the emulator's
clock, so ``clock=virtual`` drives the player as well as the servos."""

from __future__ import annotations

import importlib
import urllib.parse
from types import ModuleType

import serial

from choreo.bus.transports import Connection, open_serial, raw, refuse_direction
from choreo.emulator.bus_emulator import BusEmulator
from choreo.emulator.protocol_sim import SimSerial


def register_url_handler() -> None:
    """Let ``serial.serial_for_url`` open ``sim://`` URLs (idempotent)."""
    if "choreo.emulator" not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append("choreo.emulator")


def connect(url: str, timeout_s: float, direction=None, echo="auto") -> Connection:
    """Open a ``sim://`` URL: a new emulator (or a saved one, ``state=``) and its backend."""
    port = open_serial(url, timeout_s, raw.BAUDRATE)
    return _connection(port, port.emulator, url, direction, echo)


def connection(emulator: BusEmulator, timeout_s: float = 0.05, echo="auto") -> Connection:
    """A connection to an emulator made in this process (the built-in robot's servos, a test's):
    ``ServoBus(connection(emulator))`` talks to its servos through its board, if it has one, on
    its clock."""
    port = SimSerial.from_emulator(emulator, timeout=timeout_s)
    return _connection(port, emulator, "the built-in emulated bus", None, echo)


def host_module(url: str) -> ModuleType:
    """The module of what the host talks to on ``url``: the board ``board=`` names, or the raw
    bus."""
    board = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query).get("board", [""])[-1]
    return _board_module(board) if board else raw


def _connection(port, emulator: BusEmulator, name: str, direction, echo) -> Connection:
    if emulator.board_kind is None:
        wired = raw.connect(port, port.timeout, direction, echo, emulator.clock)
        return Connection(wired.port, wired.backend, emulator.clock, emulator)
    board = _board_module(emulator.board_kind)
    if direction is not None:
        port.close()
        raise refuse_direction(name, board.CAPABILITIES)
    return Connection(port, board.board_on(port), emulator.clock, emulator)


def _board_module(kind: str) -> ModuleType:
    return importlib.import_module(f"choreo.bus.transports.{kind}")
