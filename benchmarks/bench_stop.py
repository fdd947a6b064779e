"""How soon a signal puts the stop on the wire: `choreo play` of arm6's dance (a subprocess, as a
user runs it) on an emulator served on a pty in real time, interrupted with SIGINT once it plays.

Prints, per port kind (the raw LX bus, the RRC board, the LOBOT controller), the time from the
signal to the first byte of the stop: the raw bus's broadcast MOVE_STOP, the RRC board's stop
frame (MOVE_STOP to each servo), the LOBOT controller's position reads that precede its holds.
Goal: under 50 ms on a quiet machine. The tests check only the order and content of what reaches
the wire (tests/cli/test_play_commands.py, tests/cli/test_emulate_commands.py); this prints the
time.

Run: python benchmarks/bench_stop.py [--runs N]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from choreo.bus.protocol import Command
from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator, ServoSpec
from choreo.emulator.boards import BOARDS
from choreo.emulator.pty import PtyBridge
from choreo.emulator.trace import WireTrace
from choreo.robot.robot_file import load_robot

REPO = Path(__file__).resolve().parents[1]
# the first command of each kind's stop
STOP = {"raw": Command.MOVE_STOP, "rrc": Command.MOVE_STOP, "lobot": Command.POS_READ}


def arm_at_home(kind: str) -> BusEmulator:
    robot = load_robot("arm6")
    specs = [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, robot.pose_vector("home"))
    ]
    emulator_type = BOARDS.get(kind, BusEmulator)
    return emulator_type(specs, clock=RealClock())


# playing: the approach and two ticks are on the wire (the raw bus starts each tick with one
# broadcast MOVE_START; the boards forward a MOVE_TIME_WRITE to each of the six servos)
PLAYING = {
    "raw": (Command.MOVE_START, 3),
    "rrc": (Command.MOVE_TIME_WRITE, 18),
    "lobot": (Command.MOVE_TIME_WRITE, 18),
}


def playing(kind: str, emulator: BusEmulator) -> bool:
    command, count = PLAYING[kind]
    return sum(p.packet.command == command for p in WireTrace.of(emulator).packets) >= count


def signal_to_stop_ms(kind: str, folder: Path) -> float:
    """One play, one SIGINT: milliseconds from the signal to the stop's first packet."""
    emulator = arm_at_home(kind)
    bridge = PtyBridge(emulator, folder / f"tty{kind}")
    thread = threading.Thread(target=bridge.serve_forever, daemon=True)
    thread.start()
    port = str(bridge.link_path) if kind == "raw" else f"{kind}://{bridge.link_path}"
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "play", "motions/arm6/dance.yaml", "--port", port]
        + ["--timeout-ms", "500", "--health-timeout-ms", "100"],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},  # this checkout's choreo
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        while not playing(kind, emulator):
            if process.poll() is not None:
                raise SystemExit(f"choreo play on {port} exited early: {process.communicate()[1]}")
            time.sleep(0.002)
        sent_before = len(WireTrace.of(emulator).packets)
        pressed_s = time.monotonic()  # the emulator's RealClock is time.monotonic
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)
    finally:
        process.kill()
        bridge.stop()
        thread.join(30)
        bridge.close()
    after = WireTrace.of(emulator).packets[sent_before:]
    stop = next(p for p in after if p.packet.command == STOP[kind])
    return (stop.time_s - pressed_s) * 1000


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory() as folder:
        for kind in STOP:
            times = sorted(signal_to_stop_ms(kind, Path(folder)) for _ in range(args.runs))
            shown = ", ".join(f"{t:.1f}" for t in times)
            print(f"{kind:6} signal to stop on the wire: {shown} ms (goal < 50 ms)")


if __name__ == "__main__":
    main()
