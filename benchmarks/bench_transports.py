"""Playback through each transport, on the same motions (emulator, virtual time).

For the raw LX bus (choreo's staged moves + broadcast START), the RRC board (1,000,000 baud, one
move frame per tick, forwarded one servo at a time) and the LOBOT controller's 9600-baud UART
(the same, over a slow link): first-to-last start skew of a tick's moves, measured from the
emulated servo bus's wire log; the largest path error against the smooth plan; bytes the host
sent (motion and health reads); how late each tick's START or move frame left (in virtual time
only the link makes it late: a frame waits for the frames and reads before it); ticks re-targeted
when the link could not keep up.

Each run starts with the servos at the motion's first pose, so only playing is compared.

Run: python benchmarks/bench_transports.py
"""

from __future__ import annotations

import sys

import numpy as np

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, connection
from choreo.emulator.boards import BOARDS
from choreo.emulator.trace import WireTrace, start_skew_ms
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.path_errors import path_errors_deg
from choreo.play.player import Player
from choreo.play.preflight import preflight

MOTIONS = [
    "motions/arm6/wave.yaml",
    "motions/hexapod18/tripod_gait.yaml",
    "motions/tonypi/bow.yaml",
]
TRANSPORTS = {"raw LX bus": BusEmulator, "RRC board": BOARDS["rrc"], "LOBOT UART": BOARDS["lobot"]}
MOVE_COMMANDS = (Command.MOVE_TIME_WRITE, Command.MOVE_START)


def tick_skew_ms(wire: WireTrace, t0: float, gap_s: float = 0.0015) -> float:
    """Largest first-to-last spread of one tick's move starts: a board forwards a frame's
    moves 0.87 ms apart, so starts closer than ``gap_s`` to the previous belong to one tick."""
    moves = [m for m in wire.moves if m.command in MOVE_COMMANDS]
    return start_skew_ms(moves, since_s=t0, group_gap_s=gap_s)


def play(path: str, emulator_class) -> dict:
    motion = load_motion(path)
    robot = motion.robot
    compiled = compile_motion(motion)
    first = compiled.trajectory.at(0.0)[0]
    specs = [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, first)
    ]
    clock = VirtualClock()
    emulator = emulator_class(specs, clock=clock)
    with ServoBus(connection(emulator, timeout_s=0.05)) as bus:
        start, limits = preflight(bus, robot)
        performance = prepare(compiled, start)
        report = Player(bus, robot, clock, limits).play(performance.ticks, start)
    times = np.arange(0.0, report.planned_s, 0.002)
    wire = WireTrace.of(emulator)
    errors = path_errors_deg(
        wire.moves,
        robot,
        [j.to_units(a) for j, a in zip(robot.joints, start)],
        report.start_time_s,
        times,
        performance.planned_deg(times),
    )
    return {
        "outcome": report.outcome.value,
        "skew_ms": tick_skew_ms(wire, report.start_time_s - 0.1),
        "declared_skew_ms": report.start_skew_ms,
        "path_error_deg": max(errors),
        "bytes": report.bytes_sent,
        "retargeted": report.retargeted,
        "late_p99_ms": report.lateness_percentile_ms(99),
    }


def main() -> int:
    print(
        "| motion | transport | start skew (ms) | START / frame lateness p99 (ms) "
        "| max path error vs smooth plan (°) | bytes |"
    )
    print("|---|---|---:|---:|---:|---:|")
    for path in MOTIONS:
        for name, emulator_class in TRANSPORTS.items():
            r = play(path, emulator_class)
            note = "" if r["outcome"] == "completed" else f" ({r['outcome']})"
            if r["retargeted"]:
                note += f", re-targeted {r['retargeted']}"
            print(
                f"| {path.split('/', 1)[1].removesuffix('.yaml')} | {name}{note} | "
                f"{r['skew_ms']:.1f} (declared {r['declared_skew_ms']:.1f}) | "
                f"{r['late_p99_ms']:.1f} | "
                f"{r['path_error_deg']:.2f} | {r['bytes']:,} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
