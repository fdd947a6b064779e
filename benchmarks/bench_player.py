"""Playback figures on the emulator.

1. Real time: a >= 60 s, 18-servo motion (the hexapod's tripod gait, looped) played by choreo on
   the emulated bus with the real clock: START lateness p50/p99/max (goal p99 < 2 ms) and how far
   the end lands from the schedule (goal within 5 ms); then the same with two CPU hogs running
   beside it (one per core of a 2-core machine), at normal priority and with real-time priority
   (SCHED_FIFO + locked memory, where permitted; goal p99 < 0.5 ms), each beside a bare
   sleep-until loop on the same deadlines in the same conditions.
2. Side by side, in virtual time on the same motions, three ways of playing:
   (a) the vendor runner: per keyframe, MOVE_TIME_WRITE to each servo in turn, then sleep;
   (b) fixed 20 ms streaming: every 20 ms, MOVE_TIME_WRITE to each servo in turn;
   (c) choreo: staged moves, one broadcast MOVE_START per tick.
   Figures: first-to-last servo start skew, maximum path error against the smooth plan, bytes.

Run: python benchmarks/bench_player.py [--seconds 60] [--hogs 2] [--skip-realtime]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import subprocess
import sys

import numpy as np

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import RealClock, VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, connection, trace
from choreo.emulator.trace import WireTrace
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.dry_run import packet_schedule
from choreo.play.path_errors import path_errors_deg
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import preflight
from choreo.play.realtime import realtime_priority
from choreo.robot.types import Robot

MOTIONS = [
    "motions/arm6/wave.yaml",
    "motions/arm6/dance.yaml",
    "motions/hexapod18/tripod_gait.yaml",
]
STREAM_PERIOD_S = 0.020


def rig(robot: Robot, clock, pose_deg=None) -> tuple[BusEmulator, ServoBus]:
    """The robot's servos on an emulated bus, at ``pose_deg`` (default: home)."""
    pose_deg = robot.pose_vector("home") if pose_deg is None else pose_deg
    emulator = BusEmulator(
        [
            ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
            for j, a in zip(robot.joints, pose_deg)
        ],
        clock=clock,
    )
    return emulator, ServoBus(connection(emulator))


def realtime(seconds: float, hogs: int) -> None:
    motion = load_motion("motions/hexapod18/tripod_gait.yaml")
    one_pass = compile_motion(dataclasses.replace(motion, repeat=1)).trajectory.duration_s
    motion = dataclasses.replace(motion, repeat=int(np.ceil(seconds / one_pass)))
    compiled = compile_motion(motion)
    print(
        f"real time: {motion.robot.name} {len(motion.robot.joints)} servos, "
        f"{compiled.trajectory.duration_s:.1f} s per run, {os.cpu_count()} CPUs"
    )
    print("| conditions | scheduling | choreo START lateness | bare sleep-until loop |")
    print("|---|---|---|---|")
    figures = {}
    for name, hog_count, wanted in (
        ("quiet", 0, False),
        (f"{hogs} CPU hogs", hogs, False),
        (f"{hogs} CPU hogs, real-time priority", hogs, True),
    ):
        with cpu_hogs(hog_count):
            report, performance = play_once(motion, compiled, wanted)
            with realtime_priority() if wanted else contextlib.nullcontext():
                baseline = bare_deadlines([t.start_ms / 1000 for t in performance.ticks])
        late = np.array(report.lateness_ms)
        figures[name] = np.percentile(late, 99)
        print(
            f"| {name} | {report.scheduling.policy} | {percentiles(late)} | "
            f"{percentiles(baseline)} |"
        )
        if name == "quiet":
            quiet_end = report.end_error_ms
        if wanted and not report.scheduling.realtime:
            print(f"  ({report.scheduling.describe()})")
    print(
        f"quiet: end {quiet_end:+.3f} ms from schedule (goal within 5 ms); goals: p99 < 2 ms "
        "quiet, p99 < 0.5 ms beside the hogs with real-time priority"
    )
    print(
        "p99 START lateness (ms): "
        + ", ".join(f"{name} {p99:.3f}" for name, p99 in figures.items())
    )


def play_once(motion, compiled, realtime_wanted: bool):
    emulator, bus = rig(motion.robot, RealClock())
    start, limits = preflight(bus, motion.robot)
    performance = prepare(compiled, start)
    options = PlayOptions(realtime=realtime_wanted)
    report = Player(bus, motion.robot, RealClock(), limits, options).play(performance.ticks, start)
    return report, performance


@contextlib.contextmanager
def cpu_hogs(count: int):
    """``count`` processes that spin for as long as the block runs."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


def percentiles(late_ms: np.ndarray) -> str:
    return (
        f"p50 {np.percentile(late_ms, 50):.3f} ms, p99 {np.percentile(late_ms, 99):.3f} ms, "
        f"max {late_ms.max():.3f} ms"
    )


def bare_deadlines(offsets_s: list[float]) -> np.ndarray:
    """Lateness of an empty loop that only waits for the same deadlines with the same clock."""
    clock = RealClock()
    t0 = clock.now() + 0.01
    late = []
    for offset in offsets_s:
        clock.sleep_until(t0 + offset)
        late.append((clock.now() - t0 - offset) * 1000)
    return np.array(late)


@dataclasses.dataclass(frozen=True)
class Way:
    name: str
    skew_ms: float
    path_error_deg: float
    motion_bytes: int
    health_bytes: int = 0


def start_skew_ms(emulator: BusEmulator) -> float:
    """Largest spread of move start times within one burst of commands."""
    return trace.start_skew_ms(WireTrace.of(emulator).moves)


def written_bytes(emulator: BusEmulator, since_s: float) -> int:
    packets = WireTrace.of(emulator).packets
    return sum(len(p.packet.encode()) for p in packets if p.time_s >= since_s)


# Every way starts with the servos at the motion's first pose, so only playing is compared.
def first_pose(motion):
    return compile_motion(motion).trajectory.at(0.0)[0]


def play_choreo(motion) -> Way:
    clock = VirtualClock()
    emulator, bus = rig(motion.robot, clock, first_pose(motion))
    start, limits = preflight(bus, motion.robot)
    performance = prepare(compile_motion(motion), start)
    player = Player(bus, motion.robot, clock, limits)
    report = player.play(performance.ticks, start)
    starts = [j.to_units(a) for j, a in zip(motion.robot.joints, start)]
    times = np.arange(0.0, report.planned_s, 0.002)
    errors = path_errors_deg(
        WireTrace.of(emulator).moves,
        motion.robot,
        starts,
        report.start_time_s,
        times,
        performance.planned_deg(times),
    )
    motion_bytes = sum(len(p.packet) for p in packet_schedule(performance.ticks, motion.robot))
    return Way(
        "choreo: staged + one START per tick",
        start_skew_ms(emulator),
        max(errors),
        motion_bytes,
        report.bytes_sent - motion_bytes,
    )


def play_vendor(motion) -> Way:
    """Per keyframe: MOVE_TIME_WRITE to each servo in turn, then sleep the keyframe's time."""
    robot, trajectory = motion.robot, compile_motion(motion).trajectory
    clock = VirtualClock()
    emulator, bus = rig(robot, clock, first_pose(motion))
    bus.drain()
    t0 = clock.now()
    arrivals = (0.0,) + tuple(trajectory.keyframe_times_s)
    poses = trajectory.positions(np.array(arrivals))
    for k in range(1, len(arrivals)):
        time_ms = round((arrivals[k] - arrivals[k - 1]) * 1000)
        if time_ms <= 0:
            continue
        for joint, angle in zip(robot.joints, poses[k]):
            bus.move(joint.servo_id, round(joint.to_units(angle)), time_ms)
        bus.drain()  # the vendor's Python writes, then sleeps: the sends add up (drift)
        clock.sleep_until(clock.now() + time_ms / 1000)
    return _measure(
        "vendor runner: MOVE_TIME_WRITE per servo per keyframe", emulator, robot, trajectory, t0
    )


def play_streaming(motion) -> Way:
    """Every 20 ms, MOVE_TIME_WRITE to each servo in turn toward the plan 20 ms ahead."""
    robot, trajectory = motion.robot, compile_motion(motion).trajectory
    clock = VirtualClock()
    emulator, bus = rig(robot, clock, first_pose(motion))
    bus.drain()
    t0 = clock.now()
    steps = np.arange(STREAM_PERIOD_S, trajectory.duration_s + STREAM_PERIOD_S, STREAM_PERIOD_S)
    targets = trajectory.positions(np.minimum(steps, trajectory.duration_s))
    for k, pose in enumerate(targets):
        clock.sleep_until(t0 + k * STREAM_PERIOD_S)
        for joint, angle in zip(robot.joints, pose):
            bus.move(joint.servo_id, round(joint.to_units(angle)), round(STREAM_PERIOD_S * 1000))
    bus.drain()
    return _measure(
        "fixed 20 ms streaming: MOVE_TIME_WRITE per servo", emulator, robot, trajectory, t0
    )


def _measure(name, emulator, robot, trajectory, t0) -> Way:
    times = np.arange(0.0, trajectory.duration_s, 0.002)
    start_units = [j.to_units(a) for j, a in zip(robot.joints, trajectory.at(0.0)[0])]
    error = max(
        path_errors_deg(
            WireTrace.of(emulator).moves, robot, start_units, t0, times, trajectory.positions(times)
        )
    )
    return Way(name, start_skew_ms(emulator), error, written_bytes(emulator, t0))


def compare() -> None:
    print("\nthree ways of playing the same motions (emulator, virtual time):")
    print("| motion | way | start skew (ms) | max path error vs smooth plan (°) | motion bytes |")
    print("|---|---|---:|---:|---:|")
    for path in MOTIONS:
        motion = load_motion(path)
        for way in (play_vendor(motion), play_streaming(motion), play_choreo(motion)):
            health = f" (+{way.health_bytes} health reads)" if way.health_bytes else ""
            print(
                f"| {path.split('/', 1)[1]} | {way.name} | {way.skew_ms:.1f} | "
                f"{way.path_error_deg:.2f} | {way.motion_bytes}{health} |"
            )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="real-time run length")
    parser.add_argument("--hogs", type=int, default=2, help="CPU hogs beside the busy runs")
    parser.add_argument("--skip-realtime", action="store_true")
    args = parser.parse_args()
    if not args.skip_realtime:
        realtime(args.seconds, args.hogs)
    compare()
    return 0


if __name__ == "__main__":
    sys.exit(main())
