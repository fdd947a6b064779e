"""How fast `choreo record --continuous` can sample, and what a journaled capture costs.

Prints: the bus time of one pose read (every joint's POS_READ) on the emulated wire, exact in
virtual time; the same over a pty in real time (OS scheduling and pty latency included); and the
cost of appending one fsync'ed journal line on this disk.

    python benchmarks/bench_record.py
"""

from __future__ import annotations

import statistics
import tempfile
import threading
import time
from pathlib import Path

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import RealClock, VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, SimSerial
from choreo.emulator.pty import PtyBridge
from choreo.play.recorder import Recorder
from choreo.play.recording import Capture, Recording
from choreo.robot.robot_file import load_robot

READS = 200


def specs(robot):
    return [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, robot.pose_vector("home"))
    ]


def virtual_pose_read_ms(robot) -> float:
    clock = VirtualClock()
    bus = ServoBus(SimSerial.from_emulator(BusEmulator(specs(robot), clock=clock)))
    with tempfile.TemporaryDirectory() as folder:
        recording = Recording.start(Path(folder) / "b.yaml", robot)
        recorder = Recorder(bus, recording, clock)
        start = clock.now()
        recorder.read_pose()
        recording.close()
    return (clock.now() - start) * 1000


def pty_pose_read_ms(robot) -> list[float]:
    emulator = BusEmulator(specs(robot), clock=RealClock())
    with tempfile.TemporaryDirectory() as folder:
        bridge = PtyBridge(emulator, Path(folder) / "tty")
        thread = threading.Thread(target=bridge.serve_forever, daemon=True)
        thread.start()
        try:
            with ServoBus(str(bridge.link_path)) as bus:
                recording = Recording.start(Path(folder) / "b.yaml", robot)
                recorder = Recorder(bus, recording, RealClock())
                times = []
                for _ in range(READS):
                    start = time.perf_counter()
                    recorder.read_pose()
                    times.append((time.perf_counter() - start) * 1000)
                recording.close()
        finally:
            bridge.stop()
            thread.join(5)
            bridge.close()
    return times


def journal_append_ms(robot) -> list[float]:
    with tempfile.TemporaryDirectory() as folder:
        recording = Recording.start(Path(folder) / "b.yaml", robot)
        capture = Capture(robot.pose_vector("home"), 0.05, 1)
        times = []
        for _ in range(READS):
            start = time.perf_counter()
            recording.add(capture)
            times.append((time.perf_counter() - start) * 1000)
        recording.journal.close()
    return times


def summary(times: list[float]) -> str:
    ordered = sorted(times)
    p95 = ordered[int(0.95 * len(ordered))]
    return f"median {statistics.median(ordered):.2f} ms, p95 {p95:.2f} ms, max {ordered[-1]:.2f} ms"


def main() -> None:
    for name in ("arm6", "hexapod18"):
        robot = load_robot(name)
        wire_ms = virtual_pose_read_ms(robot)
        print(
            f"{name} ({len(robot.joints)} servos): one pose read = {wire_ms:.2f} ms of bus time "
            f"-> at most {1000 / wire_ms:.0f} Hz"
        )
        print(f"  over a pty, real time: {summary(pty_pose_read_ms(robot))}")
    print(
        f"journal append (write + flush + fsync): {summary(journal_append_ms(load_robot('arm6')))}"
    )


if __name__ == "__main__":
    main()
