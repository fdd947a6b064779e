"""Helpers for tests that run the emulator: robots standing at home, a pty served by a thread."""

from __future__ import annotations

import contextlib
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ServoSpec
from choreo.emulator.pty import PtyBridge
from choreo.robot.types import Robot

WAIT_S = 30

# Read timeouts for a `choreo` process talking to an emulator that a thread of the test process
# serves on a pty: on a loaded machine that thread can wait a second for the CPU, and the tests
# using these are about what goes on the wire, not read latency (benchmarks/ measure that).
PATIENT_READS = ("--timeout-ms", "2000", "--health-timeout-ms", "250")


def home_specs(robot: Robot) -> list[ServoSpec]:
    """The robot's servos, standing at its home pose."""
    return [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, robot.pose_vector("home"))
    ]


def recorded_writes(bus: ServoBus) -> list[bytes]:
    """Every write to ``bus``'s port from now on, as written (one entry per system call: the
    wire shows packets, not how many writes carried them)."""
    writes: list[bytes] = []
    write = bus.port.write

    def recording(data: bytes):
        writes.append(bytes(data))
        return write(data)

    bus.port.write = recording  # type: ignore[method-assign]
    return writes


def wait_for(condition, what: str, timeout_s: float = WAIT_S) -> None:
    """Poll ``condition`` until it holds; fail the test after ``timeout_s`` (never a fixed
    sleep)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        # Not faster: a condition often copies the emulator's whole wire log, holding the GIL
        # that the thread serving the pty needs; polled every 2 ms on a loaded machine, that
        # thread left a play's reads unanswered for 6 s.
        time.sleep(0.02)


@contextlib.contextmanager
def served_on_a_pty(emulator: BusEmulator, link_path: Path) -> Iterator[Path]:
    """``emulator`` on a pty linked at ``link_path``, bridged by a thread of this process (the
    emulator should run on a RealClock); the link's path inside, everything closed after."""
    bridge = PtyBridge(emulator, link_path)
    thread = threading.Thread(target=bridge.serve_forever, daemon=True)
    thread.start()
    try:
        yield bridge.link_path
    finally:
        bridge.stop()
        thread.join(WAIT_S)
        bridge.close()


def play_then_signal(
    emulator: BusEmulator, port: str, signum: int, playing: Callable[[list], bool]
) -> tuple[int, str, list]:
    """Run `choreo play` of arm6's dance on ``port`` (which ``emulator`` serves), send ``signum``
    once ``playing(the wire log so far)`` holds, and give the exit code, stderr and the packets
    logged from the signal on."""
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "play", "motions/arm6/dance.yaml", "--port", port]
        + list(PATIENT_READS),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:

        def started() -> bool:
            if process.poll() is not None:
                raise AssertionError(f"choreo play exited early: {process.communicate()[1]}")
            # list() copies at once: the bridge thread appends to the log meanwhile
            return playing(list(emulator.log.packets))

        wait_for(started, "the motion to be playing")
        sent_before = len(emulator.log.packets)  # the log only grows (far below its limit)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=30)
    finally:
        process.kill()
    return process.returncode, stderr, list(emulator.log.packets)[sent_before:]


def built_in_emulator_in_virtual_time(robot: Robot) -> BusEmulator:
    """What ``choreo.play.robot_bus.built_in_emulator`` makes (the robot at home), on a
    VirtualClock: a command played without ``--port`` takes no real time where its subject isn't
    timing (tests patch it in; see conftest.py and virtual_choreo.py)."""
    return BusEmulator(home_specs(robot), clock=VirtualClock())


def sent(emulator: BusEmulator, command: Command):
    return [p.packet for p in emulator.log.packets if p.packet.command == command]
