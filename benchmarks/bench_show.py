"""Shows on one machine: N `choreo perform` processes on emulated buses, one `choreo show`, all
on loopback (each performer listens on its own 127.0.0.1 port, the conductor connects to each).

Printed, for 3 and 8 performers (arm6 on sim://?ids=1-6 each), with the load average:
  first-START spread    per run, last minus first performer's START at the show's instant (each
                        read from its performer's clock when the START's bytes were written, on
                        this machine's one clock), and the p99 over runs and performers of each
                        START's distance from the run's median; goal p99 <= 1 ms (3), 2 ms (8);
  time to first START   from launching `choreo show` to the first START on any bus (the
                        approaches), and to the show's instant;
  stop fan-out          from SIGINT (Ctrl-C) at the conductor to the last MOVE_STOP on any bus;
                        goal < 100 ms;
  killed conductor      (SIGKILL mid-show) what every performer said and left on its bus, and
                        from the kill to the last performer saying it stopped;
  frozen conductor      (SIGSTOP mid-show: its token stays, its heartbeat stops) the same;
                        goal < 500 ms;
  killed performer      (SIGKILL mid-show) what the conductor reported and the others did;
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
    sys.path.insert(0, str(ROOT / "tests" / "show"))
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
    spreads, deviations, to_first, to_instant = [], [], [], []
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
            first = min(p["approach_start_s"] for p in report["performers"])
            to_first.append(first - launched)
            to_instant.append(report["start_s"] - launched)
    finally:
        stop_all(performers)
    print(
        f"{n:3d} performers, {runs} runs: first-START spread per run "
        f"median {np.median(spreads):.3f} ms, max {max(spreads):.3f} ms; distance from the "
        f"run's median p99 {np.percentile(deviations, 99):.3f} ms "
        "(goal <= 1 ms with 3, <= 2 ms with 8)"
    )
    print(
        f"    time from launching `choreo show` to the first START {np.median(to_first):.2f} s, "
        f"to the show's instant {np.median(to_instant):.2f} s (median)"
    )


def stop_fan_out(n: int, folder: Path) -> None:
    performers, endpoints = start_performers(n)
    report_path = folder / "stop.json"
    try:
        conductor = conduct(show_file(folder, n, WAVE), endpoints, report_path)
        for p in performers:
            p.wait_for("playing")
        time.sleep(3.0)  # into the parts (after the lead and the approach, even on a busy machine)
        sent = time.time()
        conductor.proc.send_signal(signal.SIGINT)
        conductor.proc.wait(timeout=60)
        report = json.loads(report_path.read_text())
        stops = [p["stop_s"] for p in report["performers"]]
        stopped = sum(s is not None for s in stops)
        latest = max((s for s in stops if s is not None), default=None)
        outcomes = ", ".join(sorted({p["outcome"] for p in report["performers"]}))
        took = "none" if latest is None else f"{(latest - sent) * 1000:.1f} ms"
        print(
            f"{n:3d} performers: Ctrl-C at the conductor to the last MOVE_STOP on the wire "
            f"{took} (goal < 100 ms); {stopped}/{n} buses stopped ({outcomes})"
        )
    finally:
        stop_all(performers)


def lose_conductor(n: int, folder: Path, how: str) -> None:
    """Kill (SIGKILL) or freeze (SIGSTOP) the conductor mid-show: what every performer did, and
    from the signal to the last one saying it stopped."""
    performers, endpoints = start_performers(n)
    try:
        conductor = conduct(show_file(folder, n, WAVE), endpoints, folder / "k1.json")
        for p in performers:
            p.wait_for("playing")
        time.sleep(3.0)  # into the parts
        sent = time.time()
        conductor.proc.send_signal(signal.SIGKILL if how == "killed" else signal.SIGSTOP)
        stopped = [p.said_at("part stopped: lost the conductor") for p in performers]
        said = [p.wait_for("emulated bus:") for p in performers]
        clean = sum(line.endswith("every servo stopped") for line in said)
        print(
            f"{how} conductor ({n} performers): all said they lost it within "
            f"{(max(stopped) - sent) * 1000:.0f} ms of the signal (goal < 500 ms); "
            f"{clean}/{n} buses stopped with no move after the MOVE_STOP"
        )
        conductor.proc.send_signal(signal.SIGCONT)
        conductor.proc.kill()
    finally:
        stop_all(performers)


def killed(n: int, folder: Path) -> None:
    performers, endpoints = start_performers(n)
    try:
        report_path = folder / "k2.json"
        conductor = conduct(show_file(folder, n, WAVE), endpoints, report_path)
        for p in performers:
            p.wait_for("playing")
        time.sleep(3.0)  # into the parts
        performers[0].proc.kill()
        conductor.proc.wait(timeout=60)
        parts = json.loads(report_path.read_text())["performers"]
        outcomes = [p["outcome"] for p in parts]
        print(
            f"killed performer p0 ({n} performers): conductor reported {outcomes[0]!r}; "
            f"the others: {', '.join(sorted(set(outcomes[1:])))}, "
            f"{sum(p['stop_s'] is not None for p in parts[1:])}/{n - 1} buses stopped"
        )
    finally:
        stop_all(performers)


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    print(f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())} "
          f"on {os.cpu_count()} cores")  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        for n in (3, 8):
            spread_runs(n, runs, Path(folder))
        for n in (3, 8):
            stop_fan_out(n, Path(folder))
        lose_conductor(3, Path(folder), "killed")
        lose_conductor(3, Path(folder), "frozen")
        killed(3, Path(folder))
        tls_against_plain(3, runs, Path(folder))
    print(f"load average after: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
