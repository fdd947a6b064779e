"""Health reads on an echoing bus (DIY one-wire wiring), in real time, in every echo mode.

The hexapod's tripod gait on 18 emulated LX-224HV servos that echo every host byte, as
``choreo play motions/hexapod18/tripod_gait.yaml --port 'sim://?ids=1-18&model=LX-224HV&echo=1'``
plays it with default settings. Figures per echo mode: health reads made and missed, START
lateness p50/p99, outcome. Every health read follows the echoes of up to 18 staged moves.

Run: PYTHONPATH=. python benchmarks/bench_echo.py [--loops N]
"""

from __future__ import annotations

import argparse
import dataclasses

from choreo.bus.servo_bus import EchoMode, ServoBus
from choreo.core.clock import RealClock
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.player import Player
from choreo.play.preflight import preflight

PORT = "sim://?ids=1-18&model=LX-224HV&echo=1"


def play(echo: EchoMode, loops: int | None) -> str:
    motion = load_motion("motions/hexapod18/tripod_gait.yaml")
    if loops:
        motion = dataclasses.replace(motion, repeat=loops)
    with ServoBus(PORT, echo=echo) as bus:
        start, limits = preflight(bus, motion.robot)
        performance = prepare(compile_motion(motion), start)
        report = Player(bus, motion.robot, RealClock(), limits).play(performance.ticks, start)
    reads = sum(h.reads for h in report.health)
    return (
        f"| {echo.value} | {report.outcome.value} | {reads} | {report.missed_reads} | "
        f"{report.lateness_percentile_ms(50):.2f} | {report.lateness_percentile_ms(99):.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loops", type=int, help="passes of the gait (default: the file's 4)")
    args = parser.parse_args()
    print(f"tripod_gait x{args.loops or 'repeat'} on {PORT}, real time")
    print("| --echo | outcome | health reads | missed | START p50 (ms) | START p99 (ms) |")
    print("|---|---|---:|---:|---:|---:|")
    for echo in EchoMode:
        print(play(echo, args.loops), flush=True)


if __name__ == "__main__":
    main()
