"""Round trip of POS_READ through `choreo emulate --pty` (a separate process), as a driver sees it.

The emulated wire alone takes 6 + 8 bytes at 115200 baud plus the turnaround (default 0.6 ms):
1.815 ms. Prints percentiles of the measured round trip and the overhead above that floor.
Usage: python benchmarks/emulator_pty_roundtrip.py [--count N] [--turnaround-ms X]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time

import serial

from choreo.protocol import BYTE_TIME_S, Command, encode_request


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--turnaround-ms", type=float, default=0.6)
    args = parser.parse_args()
    link = os.path.join(tempfile.mkdtemp(), "ttyEMU")
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "emulate", "--pty", link, "--servos", "1-6",
         "--turnaround-ms", str(args.turnaround_ms)],
        stdout=subprocess.PIPE, text=True,
    )
    try:
        print(process.stdout.readline().strip())
        request = encode_request(Command.POS_READ, 1)
        times = []
        with serial.Serial(link, 115200, timeout=0.1) as port:
            for _ in range(args.count):
                port.reset_input_buffer()
                start = time.perf_counter()
                port.write(request)
                reply = port.read(8)
                times.append(time.perf_counter() - start)
                assert len(reply) == 8, reply
        times.sort()
        floor_ms = ((6 + 8) * BYTE_TIME_S + args.turnaround_ms / 1000) * 1000
        print(f"{args.count} POS_READ round trips; wire floor {floor_ms:.3f} ms")
        for label, q in (("p50", 0.5), ("p90", 0.9), ("p99", 0.99), ("max", 1.0)):
            value_ms = times[min(len(times) - 1, int(q * len(times)))] * 1000
            print(f"  {label} {value_ms:.3f} ms (+{value_ms - floor_ms:.3f})")
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=5)


if __name__ == "__main__":
    main()
