"""The host's own cost of the real-time path: what ``ServoBus`` spends per packet before the
bytes reach the port, and what the frame decoders spend per byte.

The port swallows every write, so only choreo's code is timed: checking a command's fields,
encoding the packet (or a board's move frame), the lock. Per call, the best of several runs:
  stage_move   MOVE_TIME_WAIT_WRITE on the raw bus (the player sends one per changed servo)
  start        the broadcast MOVE_START of a tick
  move_many    one 18-servo tick through each transport (the raw bus: 18 MOVE_TIME_WRITEs)
  decode       a stream of replies with garbage between them, per decoder, per byte

Run: python benchmarks/bench_send.py
"""

from __future__ import annotations

import timeit

from choreo.bus.protocol import Command, PacketDecoder, encode_reply
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports import Connection, lobot, raw, rrc
from choreo.core.clock import RealClock

SERVOS = 18
MOVES = [(i, 300 + 20 * i) for i in range(1, SERVOS + 1)]


class NullPort:
    """A port that takes every write and never answers."""

    name = "null"
    timeout = 0.0

    def write(self, data: bytes) -> int:
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def flush(self) -> None: ...

    def reset_input_buffer(self) -> None: ...

    def reset_output_buffer(self) -> None: ...

    def close(self) -> None: ...


def bus_on(make_backend) -> ServoBus:
    port = NullPort()
    return ServoBus(Connection(port, make_backend(port), RealClock()))


def best_us(call, number: int) -> float:
    return min(timeit.repeat(call, number=number, repeat=7)) / number * 1e6


def main() -> None:
    buses = {
        "raw LX bus": bus_on(raw.RawBus),
        "RRC board": bus_on(rrc.RrcBoard),
        "LOBOT controller": bus_on(lobot.LobotBoard),
    }
    raw_bus = buses["raw LX bus"]
    print("| call | transport | µs per call |")
    print("|---|---|---|")
    figure = best_us(lambda: raw_bus.stage_move(3, 512, 40), 20000)
    print(f"| stage_move | raw LX bus | {figure:.2f} |")
    print(f"| start | raw LX bus | {best_us(lambda: raw_bus.start(), 20000):.2f} |")
    for name, bus in buses.items():
        figure = best_us(lambda bus=bus: bus.move_many(MOVES, 40), 2000)
        print(f"| move_many ({SERVOS} servos) | {name} | {figure:.2f} |")

    replies = b"".join(
        encode_reply(Command.POS_READ, i, pos_units=500) + b"\x00\x13" for i in range(1, 100)
    )
    rrc_frames = b"".join(
        rrc.encode_frame(rrc.FUNC_BUS_SERVO, bytes((i, 5, 0, 0xF4, 1))) + b"\x00\x13"
        for i in range(1, 100)
    )
    lobot_frames = b"".join(
        lobot.encode_frame(lobot.READ_POSITIONS, bytes((1, i, 0xF4, 1))) + b"\x00\x13"
        for i in range(1, 100)
    )
    print()
    print("| decoder | ns per byte |")
    print("|---|---|")
    for name, make, stream in (
        ("LX PacketDecoder", PacketDecoder, replies),
        ("RRC FrameDecoder", rrc.FrameDecoder, rrc_frames),
        ("LOBOT FrameDecoder", lobot.FrameDecoder, lobot_frames),
    ):
        figure = best_us(lambda make=make, stream=stream: make().feed(stream), 200)
        print(f"| {name} | {figure * 1000 / len(stream):.1f} |")


if __name__ == "__main__":
    main()
