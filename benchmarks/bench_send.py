"""The host's own cost of the real-time path: what ``ServoBus`` spends per packet before the
bytes reach the port, and what the frame decoders spend per byte.

The port swallows every write, so only choreo's code is timed: checking a command's fields,
encoding the packet (or a board's move frame), the lock. Per call, the best of several runs:
  stage_move   MOVE_TIME_WAIT_WRITE on the raw bus (the player sends one per changed servo)
  start        the broadcast MOVE_START of a tick
  move_many    one 18-servo tick through each transport (the raw bus: 18 MOVE_TIME_WRITEs)
  decode       a stream of replies with garbage between them, per decoder, per byte

Then the staging of one tick (``StagedStart.stage``: a hexapod tick that moves 16 of its 18
servos), wall and CPU time per tick, median of many: in one write as the player sends it, and
with one ``stage_move`` per servo as it did before, on
  null port         the port swallows the writes: choreo's own cost
  direction lines   a Pi UART behind GPIO direction lines (the port swallows the writes; each
                    write waits, spinning its last 2 ms, until its bytes have left at 115200)
  emulator          the emulated bus (``sim://``) on the real clock

Run: python benchmarks/bench_send.py
"""

from __future__ import annotations

import statistics
import time
import timeit

from choreo.bus.protocol import Command, PacketDecoder, encode_reply
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports import Connection, lobot, raw, rrc
from choreo.bus.transports.direction import DirectionSerial
from choreo.core.clock import RealClock
from choreo.plan.ticks import Tick
from choreo.play.tick_sending import StagedStart, staged_moves
from choreo.robot.robot_file import load_robot

SERVOS = 18
MOVES = [(i, 300 + 20 * i) for i in range(1, SERVOS + 1)]


class NullPort:
    """A port that takes every write and never answers."""

    name = "null"
    timeout = 0.0
    baudrate = 115200  # what DirectionSerial times a write's wire by

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


class NoLines:
    """GPIO direction lines that cost nothing: only the wait for the wire is timed."""

    def transmit(self) -> None: ...

    def receive(self) -> None: ...

    def close(self) -> None: ...


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

    print()
    staging()


def staging(ticks: int = 300) -> None:
    """Wall and CPU time of staging one tick, per tick, one write against one per servo."""
    robot = load_robot("hexapod18")
    home = [round(j.to_units(a)) for j, a in zip(robot.joints, robot.pose_vector("home"))]
    moved = [i not in (0, 9) for i in range(len(home))]  # 16 of 18 servos
    tick = Tick(0, 40, tuple(u + 20 * m for u, m in zip(home, moved)), tuple(moved))
    ports = {
        "null port": lambda: bus_on(raw.RawBus),
        "direction lines": lambda: bus_on(
            lambda port: raw.RawBus(DirectionSerial(port, NoLines(), RealClock(spin_s=0.002)))
        ),  # the clock a Pi UART's DirectionSerial keeps
        "emulator": lambda: ServoBus(f"sim://?ids=1-{len(home)}"),
    }
    print(f"staging one tick of {sum(moved)} servos, median of {ticks} ticks:")
    print("| port | one write: wall / CPU ms | one write per servo: wall / CPU ms |")
    print("|---|---|---|")
    for name, make in ports.items():
        figures = []
        for one_write in (True, False):
            with make() as bus:
                sending = StagedStart(bus, robot)
                wall, cpu = [], []
                for _ in range(ticks):
                    wall_s, cpu_s = time.perf_counter(), time.process_time()
                    if one_write:
                        sending.stage(tick, all_servos=False)
                    else:  # as the player staged before: one call, one write, per servo
                        for joint, pos, time_ms in staged_moves(tick, robot):
                            bus.stage_move(joint.servo_id, pos, time_ms)
                    wall.append(time.perf_counter() - wall_s)
                    cpu.append(time.process_time() - cpu_s)
                    bus.drain()
            figures.append(
                f"{statistics.median(wall) * 1000:.2f} / {statistics.median(cpu) * 1000:.2f}"
            )
        print(f"| {name} | {figures[0]} | {figures[1]} |")


if __name__ == "__main__":
    main()
