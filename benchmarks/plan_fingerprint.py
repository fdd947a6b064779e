"""Fingerprints of what ``choreo plan`` computes, to show that a speed-up changed nothing.

For every shipped motion and bench_load.py's 2,000-keyframe dance, at the file's speed and at
speed 3 (where most of them must stretch), with and without stretch: one line with the md5 of
the trajectory (its knots and polynomials, bit for bit), of the ticks with their figures, and of
the stretches, or of the error. With ``--cli`` also the md5 of what ``choreo plan`` prints (the
table and ``--json``). Paths are written relative to the checkout, so two checkouts compare:

    python benchmarks/plan_fingerprint.py --cli > before.txt    # in the checkout before
    python benchmarks/plan_fingerprint.py --cli > after.txt     # in the one after
    diff before.txt after.txt

Run: python benchmarks/plan_fingerprint.py [--cli]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from bench_load import REPO, write_dance

from choreo.errors import ChoreoError
from choreo.motion.motion_file import load_motion
from choreo.plan.pipeline import compile_motion

OPTIONS = ((None, False), (None, True), (3.0, False), (3.0, True))  # (speed, stretch)
CLI_ARGS = ([], ["--stretch"], ["--json"], ["--json", "--stretch"], ["--speed", "3"])


def md5(*parts: object) -> str:
    digest = hashlib.md5()
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(f"{part.dtype}{part.shape}".encode())
            digest.update(np.ascontiguousarray(part).tobytes())
        else:
            digest.update(repr(part).encode())
    return digest.hexdigest()


def fingerprint(path: Path, speed: float | None, stretch: bool) -> str:
    try:
        compiled = compile_motion(load_motion(path), speed=speed, stretch=stretch)
    except ChoreoError as error:
        return f"error {md5(str(error))}"
    t, ticks = compiled.trajectory, compiled.ticks
    figures = (ticks.tolerance_deg, ticks.max_deviation_deg, ticks.total_bytes, ticks.peak_bus_use)
    stretches = [(str(s.where), s.shift_s) for s in compiled.stretches]
    return (
        f"trajectory {md5(t.joint_names, t.duration_s, t.keyframe_times_s, t.knots_s, t.poly)} "
        f"ticks {md5(ticks.ticks, figures)} ({len(ticks.ticks)}) stretches {md5(stretches)}"
    )


def cli_fingerprint(path: Path, args: list[str]) -> str:
    run = subprocess.run(
        [sys.executable, "-m", "choreo", "plan", str(path), *args],
        capture_output=True,
        text=True,
        env=dict(os.environ, COLUMNS="120"),
    )
    return f"exit {run.returncode} stdout {md5(run.stdout)} stderr {md5(run.stderr)}"


def motion_files(dance: Path) -> list[tuple[Path, Path]]:
    """(folder to run in, the file from there) of each motion: relative, so that a message
    naming the file is the same in every checkout."""
    shipped = sorted((REPO / "motions").rglob("*.yaml"))
    return [(REPO, path.relative_to(REPO)) for path in shipped] + [(dance.parent, Path(dance.name))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", action="store_true", help="also run choreo plan on each")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for cwd, path in motion_files(write_dance(Path(folder))):
            os.chdir(cwd)
            for speed, stretch in OPTIONS:
                print(
                    f"{path} speed={speed} stretch={stretch}: {fingerprint(path, speed, stretch)}"
                )
            for cli_args in CLI_ARGS if args.cli else ():
                print(f"{path} choreo plan {' '.join(cli_args)}: {cli_fingerprint(path, cli_args)}")
        os.chdir(REPO)  # out of the folder before it is removed


if __name__ == "__main__":
    main()
