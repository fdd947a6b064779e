"""Helpers for tests of the emulated servos: a virtual-clock emulator driven by raw packets."""

from __future__ import annotations

from choreo.bus.protocol import (
    Command as C,
)
from choreo.bus.protocol import (
    PacketDecoder,
    decode_reply,
    encode_request,
)
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial

BYTE_S = 10 / 115200


TURNAROUND_S = 0.0006


LX16A_FULL_SWING_S = 0.16 * 240 / 60  # 1000 units = 240° at 0.16 s per 60°


TIMEOUT_S = 0.05


def hexbytes(text: str) -> bytes:
    return bytes.fromhex(text)


class Bus:
    """A virtual-clock emulator with its port and small request helpers."""

    def __init__(self, servos=(1,), **options):
        self.clock = VirtualClock()
        self.emulator = BusEmulator(servos, clock=self.clock, **options)
        self.port = SimSerial.from_emulator(self.emulator, timeout=TIMEOUT_S)

    def send(self, command, servo_id, **fields) -> None:
        self.port.write(encode_request(command, servo_id, **fields))
        self.port.flush()

    def raw_reply(self, command, servo_id, reply_len=None, **fields) -> bytes:
        self.port.reset_input_buffer()
        self.port.write(encode_request(command, servo_id, **fields))
        return self.port.read(reply_len or 16)

    def read(self, command, servo_id=1) -> dict[str, int] | None:
        packets = PacketDecoder().feed(self.raw_reply(command, servo_id))
        if not packets:
            return None
        (packet,) = packets
        return decode_reply(command, packet)

    def position(self, servo_id=1) -> int:
        return self.read(C.POS_READ, servo_id)["pos_units"]

    def wait(self, seconds: float) -> None:
        self.clock.advance(seconds)
