"""`choreo emulate --pty` (a separate process) as a driver sees it: round trips and throughput.

1. Round trip of POS_READ: 6 + 8 bytes at 115200 baud plus the turnaround (default 0.6 ms) make a
   wire floor of 1.815 ms. Prints percentiles and the overhead above that floor.
2. The same against a do-nothing responder (this script with --serve-baseline): one wake-up when
   the request arrives, one sleep until the same wire time, one write of fixed bytes. Whatever tail
   it shows comes from the machine (scheduling of two processes), not from the emulator.
3. Sustained throughput in real time: ``--stream-s`` seconds' worth of MOVE_TIME_WRITE packets
   written at once, then a MOVE_TIME_READ. The emulator must act on every packet at its wire time,
   so the read's reply (which reports the last move) arrives after all of them: prints the bytes
   per second achieved against the wire's 11,520 bytes/s and how late that reply was.
4. CPU headroom: the same stream through the emulator on a virtual clock, in bytes per CPU second.

Usage: python benchmarks/emulator_pty_roundtrip.py [--count N] [--turnaround-ms X] [--stream-s S]
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
import tty

import serial

from choreo.bus.protocol import (
    BYTE_TIME_S,
    Command,
    PacketDecoder,
    decode_reply,
    decode_request,
    encode_reply,
    encode_request,
)
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial

SERVO_IDS = range(1, 7)
BYTES_PER_S = 1 / BYTE_TIME_S  # 11,520


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--turnaround-ms", type=float, default=0.6)
    parser.add_argument("--stream-s", type=float, default=3.0)
    parser.add_argument("--serve-baseline", metavar="LINK", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve_baseline:
        serve_baseline(args.serve_baseline, args.turnaround_ms / 1000)
        return
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    floor_ms = ((6 + 8) * BYTE_TIME_S + args.turnaround_ms / 1000) * 1000
    print(f"{args.count} POS_READ round trips; wire floor {floor_ms:.3f} ms")
    emulate = [
        "-m",
        "choreo",
        "emulate",
        "--servos",
        "1-6",
        "--turnaround-ms",
        str(args.turnaround_ms),
    ]
    with serving(emulate + ["--pty"]) as link:
        print_percentiles("emulator", round_trips(link, args.count), floor_ms)
        stream = move_stream(args.stream_s)
        print_throughput(*sustained(link, stream, args.turnaround_ms / 1000), len(stream))
    with serving(
        [__file__, "--turnaround-ms", str(args.turnaround_ms), "--serve-baseline"]
    ) as link:
        print_percentiles("baseline", round_trips(link, args.count), floor_ms)
    print_headroom(stream)


class serving:
    """Runs ``python ARGS LINK`` until it prints a line, gives LINK, stops it with SIGINT."""

    def __init__(self, arguments: list[str]):
        self.link = os.path.join(tempfile.mkdtemp(), "ttyEMU")
        self.process = subprocess.Popen(
            [sys.executable, *arguments, self.link], stdout=subprocess.PIPE, text=True
        )

    def __enter__(self) -> str:
        self.process.stdout.readline()
        return self.link

    def __exit__(self, *exc_info) -> None:
        self.process.send_signal(signal.SIGINT)
        self.process.wait(timeout=5)


def round_trips(link: str, count: int) -> list[float]:
    request = encode_request(Command.POS_READ, 1)
    times = []
    with serial.Serial(link, 115200, timeout=0.1) as port:
        for _ in range(count):
            port.reset_input_buffer()
            start = time.perf_counter()
            port.write(request)
            reply = port.read(8)
            times.append(time.perf_counter() - start)
            if len(reply) != 8:
                raise SystemExit(f"a reply timed out after 100 ms (got {reply.hex(' ')})")
    return sorted(times)


def print_percentiles(label: str, times: list[float], floor_ms: float) -> None:
    parts = []
    for name, q in (("p50", 0.5), ("p90", 0.9), ("p99", 0.99), ("max", 1.0)):
        value_ms = times[min(len(times) - 1, int(q * len(times)))] * 1000
        parts.append(f"{name} {value_ms:.3f} (+{value_ms - floor_ms:.3f})")
    print(f"  {label:8} " + "  ".join(parts) + " ms")


def move_stream(duration_s: float) -> bytes:
    """MOVE_TIME_WRITE to servo after servo, ``duration_s`` of wire time; targets vary."""
    packets = []
    while len(packets) * 10 < duration_s * BYTES_PER_S:
        n = len(packets)
        packets.append(
            encode_request(
                Command.MOVE_TIME_WRITE,
                SERVO_IDS[n % len(SERVO_IDS)],
                pos_units=(n * 37) % 1001,
                time_ms=20,
            )
        )
    return b"".join(packets)


def sustained(link: str, stream: bytes, turnaround_s: float) -> tuple[float, float]:
    """(seconds from the first write to the last reply byte, seconds that reply was late)."""
    *_, last = PacketDecoder().feed(stream)
    read = encode_request(Command.MOVE_TIME_READ, last.servo_id)
    with serial.Serial(link, 115200, timeout=30) as port:
        port.reset_input_buffer()
        start = time.perf_counter()
        port.write(stream + read)
        reply = port.read(10)
        elapsed_s = time.perf_counter() - start
    (packet,) = PacketDecoder().feed(reply)
    if decode_reply(Command.MOVE_TIME_READ, packet) != decode_request(last):
        raise SystemExit("the emulator did not act on the last move of the stream")
    wire_s = (len(stream) + len(read) + len(reply)) * BYTE_TIME_S + turnaround_s
    return elapsed_s, elapsed_s - wire_s


def print_throughput(elapsed_s: float, late_s: float, stream_bytes: int) -> None:
    rate = stream_bytes / elapsed_s
    print(
        f"sustained: {stream_bytes} bytes of MOVE_TIME_WRITE in {elapsed_s:.3f} s = {rate:,.0f} "
        f"bytes/s ({rate / BYTES_PER_S:.1%} of the wire's {BYTES_PER_S:,.0f}); "
        f"the read after them came {late_s * 1000:.2f} ms after its wire time"
    )


def print_headroom(stream: bytes) -> None:
    port = SimSerial.from_emulator(BusEmulator(SERVO_IDS, clock=VirtualClock()), timeout=1)
    start = time.process_time()
    port.write(stream)
    port.flush()
    cpu_s = time.process_time() - start
    print(
        f"CPU headroom: the emulator handles {len(stream) / cpu_s:,.0f} bytes per CPU second "
        f"({len(stream) / cpu_s / BYTES_PER_S:.1f}x the wire)"
    )


def serve_baseline(link: str, turnaround_s: float) -> None:
    """A do-nothing POS_READ responder with the emulator's wire timing (for the comparison)."""
    master, slave = os.openpty()
    tty.setraw(slave)
    os.symlink(os.ttyname(slave), link)
    reply = encode_reply(Command.POS_READ, 1, pos_units=500)
    stopping = []
    signal.signal(signal.SIGINT, lambda *_: stopping.append(True))
    print("serving", flush=True)
    pending = b""
    while not stopping:
        try:
            readable, _, _ = select.select([master], [], [], 0.1)
        except InterruptedError:
            continue
        if not readable:
            continue
        arrived_s = time.monotonic()
        pending += os.read(master, 4096)
        while len(pending) >= 6:
            pending = pending[6:]
            due_s = arrived_s + (6 + len(reply)) * BYTE_TIME_S + turnaround_s
            remaining_s = due_s - time.monotonic()
            if remaining_s > 0:
                select.select([], [], [], remaining_s)
            os.write(master, reply)
    os.unlink(link)


if __name__ == "__main__":
    main()
