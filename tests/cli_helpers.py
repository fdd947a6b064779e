"""Helpers for tests that run the command line as a user does: the one error line it prints,
argparse's refusal, a small motion file, a `choreo` subprocess."""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import pytest
from paths import REPO

from choreo.cli import main

WAVE = REPO / "motions" / "arm6" / "wave.yaml"


def motion_file(tmp_path: Path, keyframes: str, *, name: str = "m.yaml", head: str = "") -> Path:
    """An arm6 motion from home through ``keyframes`` (YAML list items), at line 5 on."""
    path = tmp_path / name
    path.write_text(f"name: m\nrobot: arm6\n{head}keyframes:\n  - pose: home\n{keyframes}")
    return path


def error_line(capsys) -> str:
    """The one line on stderr (asserting there is exactly one)."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.rstrip("\n")


def usage_error_line(capsys, argv: list[str]) -> str:
    """argparse's refusal: exit 2, its usage, then one line saying what is wrong."""
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    return capsys.readouterr().err.splitlines()[-1]


def choreo_process(*argv: str, stdin=None) -> subprocess.Popen:
    """``python -m choreo *argv`` in the repository, its output captured as text."""
    return subprocess.Popen(
        [sys.executable, "-m", "choreo", *argv],
        cwd=REPO,
        stdin=stdin,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def packets(emulator, command: str) -> list:
    """The logged packets of one command (by name), in the order they came."""
    from choreo.bus.protocol import Command

    # list() copies at once: a bridge thread may append meanwhile
    return [p for p in list(emulator.log.packets) if p.packet.command == Command[command]]


ARM6_D6A_ROWS = (
    ("Servo1", "Servo2", "Servo3"),
    ((1, 500, (500, 500, 700)), (2, 800, (625, 400, 580))),
)


def write_d6a(path: Path) -> Path:
    """A small vendor action group: three columns, two rows."""
    from choreo.interop.d6a import ActionRow, write_action_group

    columns, rows = ARM6_D6A_ROWS
    write_action_group(path, columns, [ActionRow(*row) for row in rows])
    return path


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def mirror(source: Path, out: Path) -> Path:
    assert main(["mirror", str(source), "-o", str(out)]) == 0
    return out


PREVIEW_MOTIONS = Path("tests/data/preview/motions")
