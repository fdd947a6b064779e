"""Shows on one machine: N `choreo perform` processes on emulated buses, one `choreo show`, all
on loopback (each performer listens on its own 127.0.0.1 port, the conductor connects to each).

Printed, for 3 and 8 performers (arm6 on sim://?ids=1-6 each), with the load average:
  first-START spread    per run, last minus first performer's START at the show's instant (each
                        read from its performer's clock when the START's bytes were written, on
                        this machine's one clock), and the p99 over runs and performers of each
                        START's distance from the run's median; goal p99 <= 1 ms (3), 2 ms (8);
  time to first START   from launching `choreo show` to the first START on any bus (the
                        approaches), and to the show's instant;
  stop latency          from the signal to the last MOVE_STOP on the wire of any bus (as the
                        emulated bus timestamps it, on this machine's one wall clock), and why
                        each performer stopped:
    Ctrl-C              SIGINT at the conductor (a signed stop); goal < 100 ms;
    killed conductor    SIGKILL mid-show (its liveliness token vanishes); goal < 500 ms;
    frozen conductor    SIGSTOP mid-show (its token stays, its heartbeat stops: the silence bound
                        of 400 ms stops them); also from its last heartbeat to the MOVE_STOP
                        written; goal < 500 ms from the signal;
    killed performer    SIGKILL of one performer mid-show (the conductor sees it lost and stops
                        the others, on_abort: stop); goal < 500 ms;
  TLS against plain     from launching `choreo show` to the first START, mutual TLS (the TLS
                        tests' certificates) and plain TCP.

Needs the show extra (pip install 'choreo[show]'). Run: python benchmarks/bench_show.py [RUNS]
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from datetime import datetime
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
NOD = ROOT / "tests" / "data" / "shows" / "nod.yaml"  # 1 s
WAVE = ROOT / "motions" / "arm6" / "wave.yaml"  # 4.9 s: long enough to stop mid-show
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Choreo:
    """`python -m choreo ARGS` in the background, its stderr lines collected."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "choreo", *args],
            env=ENV,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.err: list[str] = []
        self.out: list[str] = []
        self.err_at: list[float] = []  # when each stderr line was read (wall clock)
        for stream, into, at in (
            (self.proc.stderr, self.err, self.err_at),
            (self.proc.stdout, self.out, []),
        ):
            threading.Thread(target=self._read, args=(stream, into, at), daemon=True).start()

    @staticmethod
    def _read(stream, into: list[str], at: list[float]) -> None:
        for line in stream:
            at.append(time.time())
            into.append(line.rstrip("\n"))

    def said_at(self, text: str, after: int = 0) -> float:
        """When the first stderr line with ``text`` from line ``after`` on was read."""
        line = self.wait_for(text, after=after)
        return self.err_at[self.err.index(line, after)]

    def wait_for(self, text: str, lines: list[str] | None = None, after: int = 0) -> str:
        """The first line with ``text`` from line ``after`` on."""
        lines = self.err if lines is None else lines
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            for line in list(lines)[after:]:
                if text in line:
                    return line
            time.sleep(0.005)
        raise RuntimeError(f"{text!r} never came: {self.err}")


def start_performers(
    n: int, protocol: str = "tcp", config: tuple[str, ...] = ()
) -> tuple[list[Choreo], list[str]]:
    performers, endpoints = [], []
    for i in range(n):
        port = free_port()
        performers.append(
            Choreo(
                "perform", "--name", f"p{i}", "--port", "sim://?ids=1-6",
                "--listen", f"{protocol}/127.0.0.1:{port}", *config,
            )
        )  # fmt: skip
        endpoints.append(f"{protocol}/127.0.0.1:{port}")
    for p in performers:
        p.wait_for("waiting for a show", p.out)
    return performers, endpoints


def stop_all(processes: list[Choreo]) -> None:
    for p in processes:
        if p.proc.poll() is None:
            p.proc.send_signal(signal.SIGINT)
    for p in processes:
        try:
            p.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.proc.kill()


def show_file(folder: Path, n: int, motion: Path) -> Path:
    lines = ["name: bench", "on_abort: stop", "performers:"]
    lines += [f"  - {{name: p{i}, motion: {motion}}}" for i in range(n)]
    path = folder / f"show{n}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def conduct(show: Path, endpoints: list[str], report: Path, config: tuple[str, ...] = ()) -> Choreo:
    connects = [a for e in endpoints for a in ("--connect", e)]
    return Choreo(
        "show", str(show), "--no-audio", "--go", "--report", str(report), *connects, *config
    )


def tls_against_plain(n: int, runs: int, folder: Path) -> None:
    """Time from launching `choreo show` to the first START, plain TCP and mutual TLS."""
    sys.path.insert(0, str(ROOT / "tests"))
    from show_helpers import make_certificates, tls_config  # the TLS tests' certificates

    certificates = folder / "tls"
    certificates.mkdir()
    make_certificates(certificates)
    performer_config = ("--zenoh-config", str(tls_config(certificates, "performer")))
    conductor_config = ("--zenoh-config", str(tls_config(certificates, "conductor")))
    show, report_path = show_file(folder, n, NOD), folder / "tls.json"
    for protocol, mine, theirs in (
        ("tcp", (), ()),
        ("tls", performer_config, conductor_config),
    ):
        performers, endpoints = start_performers(n, protocol, mine)
        to_first = []
        try:
            for _ in range(runs):
                launched = time.time()
                conductor = conduct(show, endpoints, report_path, theirs)
                if conductor.proc.wait(timeout=120) != 0:
                    raise RuntimeError("\n".join(conductor.err))
                report = json.loads(report_path.read_text())
                to_first.append(min(p["approach_start_s"] for p in report["performers"]) - launched)
        finally:
            stop_all(performers)
        print(
            f"{protocol} ({n} performers, {runs} runs): launching `choreo show` to the first "
            f"START, median {np.median(to_first):.2f} s"
        )


def spread_runs(n: int, runs: int, folder: Path) -> None:
    performers, endpoints = start_performers(n)
    show, report_path = show_file(folder, n, NOD), folder / "report.json"
    spreads, deviations, late, to_first, to_instant = [], [], [], [], []
    try:
        for _ in range(runs):
            launched = time.time()
            conductor = conduct(show, endpoints, report_path)
            if conductor.proc.wait(timeout=120) != 0:
                raise RuntimeError("\n".join(conductor.err))
            report = json.loads(report_path.read_text())
            starts = np.array([p["first_start_s"] for p in report["performers"]])
            spreads.append((starts.max() - starts.min()) * 1000)
            deviations += list(np.abs(starts - np.median(starts)) * 1000)
            late += [p["first_start_late_ms"] for p in report["performers"]]
            first = min(p["approach_start_s"] for p in report["performers"])
            to_first.append(first - launched)
            to_instant.append(report["start_s"] - launched)
    finally:
        stop_all(performers)
    print(
        f"{n:3d} performers, {runs} runs (load {os.getloadavg()[0]:.1f}): first-START spread "
        f"per run p50 {np.median(spreads):.3f} ms, p99 {np.percentile(spreads, 99):.3f} ms, max "
        f"{max(spreads):.3f} ms (goal p99 <= 1 ms with 3, <= 2 ms with 8); distance from the "
        f"run's median p99 {np.percentile(deviations, 99):.3f} ms; first START written after "
        f"it was due p50 {np.median(late):.3f} ms, max {max(late):.3f} ms"
    )
    print(
        f"    time from launching `choreo show` to the first START {np.median(to_first):.2f} s, "
        f"to the show's instant {np.median(to_instant):.2f} s (median)"
    )


def time_of_day_s(wall_s: float) -> float:
    moment = datetime.fromtimestamp(wall_s)
    return moment.hour * 3600 + moment.minute * 60 + moment.second + moment.microsecond / 1e6


def said_time_s(line: str, after: str, near_s: float) -> float:
    """The wall-clock instant a performer's line gives as HH:MM:SS.ffffff after ``after``
    (local time of day), taken on the day of ``near_s``."""
    text = line.split(after, 1)[1][:15]
    hours, minutes, seconds = text.split(":")
    of_day = int(hours) * 3600 + int(minutes) * 60 + float(seconds)
    delta = (of_day - time_of_day_s(near_s) + 43200) % 86400 - 43200  # across midnight too
    return near_s + delta


def summary(latencies_ms: list[float]) -> str:
    values = np.array(latencies_ms)
    return f"median {np.median(values):.0f} ms, max {values.max():.0f} ms over {len(values)} runs"


def stop_fan_out(n: int, runs: int, folder: Path) -> None:
    """Ctrl-C (SIGINT) at the conductor mid-show, ``runs`` times: from the signal to the last
    MOVE_STOP on the wire, from the report (each performer's emulated bus)."""
    performers, endpoints = start_performers(n)
    report_path = folder / "stop.json"
    latencies, causes, stopped = [], set(), 0
    try:
        for _ in range(runs):
            seen = [len(p.err) for p in performers]
            conductor = conduct(show_file(folder, n, WAVE), endpoints, report_path)
            for p, after in zip(performers, seen):
                p.wait_for("playing", after=after)
            time.sleep(2.0)  # into the parts (after the lead and the approach)
            sent = time.time()
            conductor.proc.send_signal(signal.SIGINT)
            conductor.proc.wait(timeout=60)
            parts = json.loads(report_path.read_text())["performers"]
            stops = [p["stop_s"] for p in parts if p["stop_s"] is not None]
            stopped += len(stops)
            causes |= {str(p["stop_cause"]) for p in parts}
            if stops:
                latencies.append((max(stops) - sent) * 1000)
    finally:
        stop_all(performers)
    print(
        f"Ctrl-C at the conductor ({n} performers): signal to the last MOVE_STOP on the wire "
        f"{summary(latencies)} (goal < 100 ms); stopped by: {', '.join(sorted(causes))}; "
        f"{stopped}/{n * runs} buses stopped"
    )


def lose_conductor(n: int, runs: int, folder: Path, how: str) -> None:
    """Kill (SIGKILL) or freeze (SIGSTOP) the conductor mid-show, ``runs`` times: from the
    signal to the last MOVE_STOP on the wire, why each performer stopped, and whether anything
    moved after."""
    performers, endpoints = start_performers(n)
    latencies, since_beat, causes, clean = [], [], set(), 0
    try:
        for _ in range(runs):
            seen = [len(p.err) for p in performers]
            conductor = conduct(show_file(folder, n, WAVE), endpoints, folder / "k1.json")
            for p, after in zip(performers, seen):
                p.wait_for("playing", after=after)
            time.sleep(2.0)  # into the parts (after the lead and the approach)
            sent = time.time()
            conductor.proc.send_signal(signal.SIGKILL if how == "killed" else signal.SIGSTOP)
            wire = [p.wait_for("emulated bus:", after=a) for p, a in zip(performers, seen)]
            stops = [p.wait_for("servos stopped (", after=a) for p, a in zip(performers, seen)]
            on_wire = [said_time_s(line, "on the wire at ", sent) for line in wire]
            latencies.append((max(on_wire) - sent) * 1000)
            since_beat += [float(line.split("written at ")[1].split(", ")[1].split(" ms")[0])
                           for line in stops]  # fmt: skip
            causes |= {line.split("servos stopped (")[1].split(")")[0] for line in stops}
            clean += sum(line.endswith("every servo stopped") for line in wire)
            conductor.proc.send_signal(signal.SIGCONT)
            conductor.proc.kill()
            conductor.proc.wait()
    finally:
        stop_all(performers)
    print(
        f"{how} conductor ({n} performers): signal to the last MOVE_STOP on the wire "
        f"{summary(latencies)} (goal < 500 ms); last heartbeat to MOVE_STOP written: median "
        f"{np.median(since_beat):.0f} ms, max {max(since_beat):.0f} ms; stopped by: "
        f"{', '.join(sorted(causes))}; {clean}/{n * runs} buses with no move after the MOVE_STOP"
    )


def killed(n: int, runs: int, folder: Path) -> None:
    """Kill (SIGKILL) performer p0 mid-show, ``runs`` times: from the kill to the others' last
    MOVE_STOP on the wire (the conductor's stop, on_abort: stop), from the report."""
    latencies, reported, causes, stopped = [], set(), set(), 0
    report_path = folder / "k2.json"
    for _ in range(runs):
        performers, endpoints = start_performers(n)
        try:
            conductor = conduct(show_file(folder, n, WAVE), endpoints, report_path)
            for p in performers:
                p.wait_for("playing")
            time.sleep(2.0)  # into the parts
            sent = time.time()
            performers[0].proc.kill()
            conductor.proc.wait(timeout=60)
            parts = json.loads(report_path.read_text())["performers"]
            reported.add(parts[0]["outcome"])
            causes |= {str(p["stop_cause"]) for p in parts[1:]}
            stops = [p["stop_s"] for p in parts[1:] if p["stop_s"] is not None]
            stopped += len(stops)
            if stops:
                latencies.append((max(stops) - sent) * 1000)
        finally:
            stop_all(performers)
    print(
        f"killed performer p0 ({n} performers): kill to the others' last MOVE_STOP on the wire "
        f"{summary(latencies)} (goal < 500 ms); p0 reported {', '.join(sorted(reported))}; "
        f"others stopped by: {', '.join(sorted(causes))}; {stopped}/{(n - 1) * runs} buses stopped"
    )


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
          f"on {os.cpu_count()} cores")  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        for n in (3, 8):
            spread_runs(n, runs, Path(folder))
        for n in (3, 8):
            stop_fan_out(n, runs, Path(folder))
        lose_conductor(3, runs, Path(folder), "killed")
        lose_conductor(3, runs, Path(folder), "frozen")
        killed(3, runs, Path(folder))
        tls_against_plain(3, runs, Path(folder))
    print(f"load average after: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
