"""Helpers for tests that run the command line as a user does: the one error line it prints,
argparse's refusal, a small motion file, a `choreo` subprocess, or main(argv) here with
something done meanwhile (a signal sent, a process killed)."""

from __future__ import annotations

import io
import os
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from paths import REPO

from choreo.cli import main

WAVE = REPO / "motions" / "arm6" / "wave.yaml"
PROCESS_WAIT_S = 60.0  # the most a ChoreoProcess step may take (never reached when working)


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


def main_while(
    monkeypatch, meanwhile: Callable[[Callable[[], str]], None], argv: list[str]
) -> tuple[int, str, str]:
    """main(argv) run here while ``meanwhile`` runs in a thread of its own, reading what the
    command has said so far on stderr: exit code, stdout, stderr. What ``meanwhile`` raised is
    raised here once the command is over."""
    out, said = io.StringIO(), io.StringIO()  # read as written: the GIL keeps each write whole
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stderr", said)
    failed: list[BaseException] = []

    def run() -> None:
        try:
            meanwhile(said.getvalue)
        except BaseException as error:  # raised in the test's thread, below
            failed.append(error)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    code = main(argv)
    thread.join(timeout=PROCESS_WAIT_S)
    if failed:
        raise failed[0]
    return code, out.getvalue(), said.getvalue()


def said_eventually(said: Callable[[], str], text: str) -> None:
    """Wait until ``said()`` holds ``text`` (as Transcript.wait_for does for a process)."""
    deadline = time.monotonic() + PROCESS_WAIT_S
    while text not in said():
        assert time.monotonic() < deadline, f"{text!r} never came; got:\n{said()}"
        time.sleep(0.02)


@contextmanager
def signal_noted(signum: int) -> Iterator[list[int]]:
    """Inside, ``signum`` sent to this process (os.kill) while the command's own handler is not
    in place is noted in the list given, not acted on (its default would end the test run): a
    command that failed to take it over then runs on, and the test can tell."""
    noted: list[int] = []
    previous = signal.signal(signum, lambda number, _: noted.append(number))
    try:
        yield noted
    finally:
        signal.signal(signum, previous)


def play_here_then_signal(
    monkeypatch, emulator, port: str, signum: int, playing: Callable[[list], bool], *extra: str
) -> tuple[int, str, list]:
    """emulated.play_then_signal, with `choreo play` run here (main_while) and the signal sent
    to this process: the exit code, stderr and the packets logged from the signal on. A signal
    that reached no handler of the command's fails the test. ``extra``: more arguments."""
    from emulated import PATIENT_READS, wait_for

    logged_before: list[int] = []

    def signal_once_playing(_said: Callable[[], str]) -> None:
        # list() copies at once: the bridge thread appends to the log meanwhile
        wait_for(lambda: playing(list(emulator.log.packets)), "the motion to be playing")
        logged_before.append(len(emulator.log.packets))  # the log only grows
        os.kill(os.getpid(), signum)

    argv = ["play", "motions/arm6/dance.yaml", "--port", port, *PATIENT_READS, *extra]
    with signal_noted(signum) as unhandled:
        code, _, err = main_while(monkeypatch, signal_once_playing, argv)
    assert unhandled == [], f"no handler of choreo play's took signal {signum}"
    return code, err, list(emulator.log.packets)[logged_before[0] :]


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


class Transcript:
    """The lines something said, read page by page: a process that serves several tests (a
    performer) turns a page for each; ``lines`` and ``wait_for`` then read only the lines said
    since (``every_line``: all of them). ``wait_for`` gives up once nothing more can come."""

    def __init__(self) -> None:
        self.every_line: list[str] = []  # on stderr, for a process
        self._page = 0  # the index in every_line of the first line of this page
        self._out: list[str] = []  # on stdout, for a process

    @property
    def lines(self) -> list[str]:
        """The lines said since the page was turned."""
        return self.every_line[self._page :]

    def turn_page(self) -> None:
        """From now on ``lines`` and ``wait_for`` read only the lines said after this."""
        self._page = len(self.every_line)

    def ended(self) -> bool:
        """Whether nothing more will be said."""
        return False

    def wait_for(self, text: str, stream: str = "stderr") -> str:
        deadline = time.monotonic() + PROCESS_WAIT_S
        while time.monotonic() < deadline:
            lines = self.lines if stream == "stderr" else self._out
            found = [line for line in lines if text in line]
            if found:
                return found[0]
            if self.ended():
                break
            time.sleep(0.02)
        raise AssertionError(f"{text!r} never came; got:\n" + "\n".join(self.lines + self._out))


class ChoreoProcess(Transcript):
    """A choreo command in the background, its stdout and stderr collected line by line;
    ``prefix`` runs it through another command (``ip netns exec NS``)."""

    def __init__(
        self, *args: str, stdin: int | None = subprocess.DEVNULL, prefix: tuple[str, ...] = ()
    ):
        super().__init__()
        self.proc = subprocess.Popen(
            [*prefix, sys.executable, "-m", "choreo", *args],
            cwd=REPO,
            env={**os.environ, "PYTHONPATH": str(REPO)},
            stdin=stdin,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self._readers = [
            threading.Thread(
                target=self._read, args=(self.proc.stderr, self.every_line), daemon=True
            ),
            threading.Thread(target=self._read, args=(self.proc.stdout, self._out), daemon=True),
        ]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(stream, into: list[str]) -> None:
        for line in stream:
            into.append(line.rstrip("\n"))

    def ended(self) -> bool:
        return self.proc.poll() is not None and not any(r.is_alive() for r in self._readers)

    def finish(self) -> tuple[int, str]:
        code = self.proc.wait(timeout=PROCESS_WAIT_S)
        for reader in self._readers:
            reader.join(timeout=PROCESS_WAIT_S)
        return code, "\n".join(self.every_line)

    @property
    def stdout(self) -> str:
        return "\n".join(self._out)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=PROCESS_WAIT_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()
