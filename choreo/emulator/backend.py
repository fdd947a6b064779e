"""The emulator as a transport backend: ``sim://``, added to the bus's backends by choreo's own
entry point (``choreo.backends``: ``sim = "choreo.emulator.backend"``), so the bus never imports
this layer. It keeps the contract every backend keeps (:class:`~choreo.bus.transports.Transport`):
the host talks to the emulated servos as it would to real ones, on the raw LX bus or through the
emulated board the URL names (``sim://?board=rrc``), and the bus keeps time on the emulator's
clock, so ``clock=virtual`` drives the player as well as the servos."""

from __future__ import annotations

import urllib.parse

import serial

from choreo.bus.transports import (
    BytePort,
    Connection,
    Direction,
    Echo,
    Link,
    open_serial,
    raw,
    refuse_direction,
)
from choreo.emulator.boards import BOARDS
from choreo.emulator.bus_emulator import BusEmulator
from choreo.emulator.protocol_sim import SimSerial
from choreo.errors import PortError


def register_url_handler() -> None:
    """Let ``serial.serial_for_url`` open ``sim://`` URLs (idempotent)."""
    if "choreo.emulator" not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append("choreo.emulator")


def connect(
    url: str, timeout_s: float, direction: Direction | None = None, echo: Echo = "auto"
) -> Connection:
    """Open a ``sim://`` URL: a new emulator (or a saved one, ``state=``) and its backend."""
    port = open_serial(url, timeout_s, raw.BAUDRATE)
    return _connection(port, port.emulator, url, direction, echo)


def connection(emulator: BusEmulator, timeout_s: float = 0.05, echo: Echo = "auto") -> Connection:
    """A connection to an emulator made in this process (the built-in robot's servos, a test's):
    ``ServoBus(connection(emulator))`` talks to its servos through its board, if it has one, on
    its clock."""
    port = SimSerial.from_emulator(emulator, timeout=timeout_s)
    return _connection(port, emulator, "the built-in emulated bus", None, echo)


def link(url: str) -> Link:
    """What the host speaks on ``url``: the frames of the board ``board=`` names, or the raw
    bus."""
    board = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query).get("board", [""])[-1]
    if not board:
        return raw.LINK
    if board not in BOARDS:
        raise PortError(f"{url}: board must be one of {', '.join(BOARDS)}, got {board!r}")
    return BOARDS[board].host_link


def _connection(
    port: BytePort, emulator: BusEmulator, name: str, direction: Direction | None, echo: Echo
) -> Connection:
    if emulator.board_kind is None:
        wired = raw.connect(port, port.timeout, direction, echo, emulator.clock)
        return Connection(wired.port, wired.backend, emulator.clock, emulator)
    board = BOARDS[emulator.board_kind].host_link
    if direction is not None:
        port.close()
        raise refuse_direction(name, board.capabilities)
    return Connection(port, board.backend_on(port), emulator.clock, emulator)
