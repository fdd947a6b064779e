"""Why a read got no valid reply, said in one line: its echo never came back (a bus not wired
one-wire), its replies failed the checksum (two servos on one ID, noisy wiring), or no servo
answered. ``ServoBus.request`` raises what :func:`no_reply_error` makes of its tries."""

from __future__ import annotations

from dataclasses import dataclass

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.errors import BusError, BusTimeoutError, ProtocolError


@dataclass(frozen=True)
class FailedTries:
    """What the tries of one read saw, none of them a valid reply."""

    count: int
    timeout_s: float  # of each try
    garbled: int  # replies that failed the checksum
    echo_seen: bool  # False: DISCARD mode, and not one try saw its request come back
    received: bytes  # what the first try that received anything received

    @property
    def text(self) -> str:
        each_ms = f"{self.timeout_s * 1000:.0f} ms"
        return f"1 try of {each_ms}" if self.count == 1 else f"{self.count} tries, {each_ms} each"


def no_reply_error(port_name: str, servo_id: int, command: Command, tries: FailedTries) -> BusError:
    """The error for a read of ``command`` from ``servo_id`` on ``port_name`` that ``tries``
    failed to get answered: a ``ProtocolError`` when something came back wrong, else a
    ``BusTimeoutError``."""
    concerned_id = None if servo_id == BROADCAST_ID else servo_id
    if not tries.echo_seen:
        return ProtocolError(
            f"{port_name}: expected the echo of the request, got "
            f"{tries.received.hex(' ') or 'nothing'}: is the bus really wired "
            "one-wire? try echo mode 'none' or 'auto'",
            servo_id=concerned_id,
            command=command,
        )
    garbled = tries.garbled
    replies = f"{garbled} repl{'y' if garbled == 1 else 'ies'} to"
    if garbled and servo_id == BROADCAST_ID:
        return ProtocolError(
            f"{replies} a broadcast {command.name} failed the checksum ({tries.text}): "
            "several servos answered at once (a broadcast read needs a single servo on the "
            "bus), or the wiring is noisy",
            servo_id=concerned_id,
            command=command,
        )
    if garbled:
        return ProtocolError(
            f"servo {servo_id}: {replies} {command.name} failed the checksum ({tries.text}): "
            f"two servos may share ID {servo_id} (run `choreo scan`), or the wiring is noisy",
            servo_id=concerned_id,
            command=command,
        )
    silent = "no servo answered" if servo_id == BROADCAST_ID else f"servo {servo_id} did not answer"
    return BusTimeoutError(
        f"{silent} {command.name} on {port_name} ({tries.text}): check power and wiring, "
        "or run `choreo scan`",
        servo_id=concerned_id,
        command=command,
    )
