"""Performers on loopback for the show command tests: `choreo perform` processes, where the
process is what a test is about (killed, or its start-up), else performers in the test's own
process, saying what `choreo perform` prints (each `choreo` process costs about 0.8 s of CPU to
start); and the troupe of them that several tests share, a performer serving show after show."""

from __future__ import annotations

import time

from cli_helpers import PROCESS_WAIT_S, Transcript
from cli_helpers import ChoreoProcess as Process
from show_helpers import Stage, free_port

ARM = "sim://?ids=1-6"
# A conductor's heartbeat comes every 100 ms; on a machine loaded by other work it was seen
# 408-476 ms apart, past the default 400 ms bound, and the parts stopped. Tests of anything but
# that bound give their performers this much patience; the frozen-conductor test keeps the default
# (silence_ms=None: no flag).
PATIENT_SILENCE_MS = 2000
# A performer's line when it takes a part, and the last it says of a part (on an emulated bus)
STAGED = ": preflight passed"
PART_ENDS = ("part dropped, ", ": emulated bus: ")


def perform(
    name: str, *extra: str, port: str = ARM, silence_ms: int | None = PATIENT_SILENCE_MS
) -> tuple[Process, str]:
    """A `choreo perform` on loopback, starting: (process, its endpoint)."""
    listen = f"tcp/127.0.0.1:{free_port()}"
    patience = () if silence_ms is None else ("--max-silence-ms", str(silence_ms))
    process = Process(
        "perform", *("--name", name, "--port", port, "--listen", listen), *patience, *extra
    )
    return process, listen


def performer_process(
    name: str, *extra: str, port: str = ARM, silence_ms: int | None = PATIENT_SILENCE_MS
) -> tuple[Process, str]:
    """A performer of its own, waiting for a show: (process, its endpoint)."""
    process, listen = perform(name, *extra, port=port, silence_ms=silence_ms)
    process.wait_for("waiting for a show", stream="stdout")
    return process, listen


class PerformerHere(Transcript):
    """A performer serving in this process (show_helpers.Stage), on loopback: its lines are
    those `choreo perform` prints on stderr (``NAME: ...``), its pid this process's."""

    def __init__(self, name: str, port: str = ARM, silence_ms: float = PATIENT_SILENCE_MS):
        super().__init__()
        self.stage = Stage(
            silence_ms / 1000,
            name=name,
            port=port,
            say=lambda text: self.every_line.append(f"{name}: {text}"),
        )
        self.endpoint = self.stage.endpoint

    def ended(self) -> bool:
        return not self.stage.thread.is_alive()

    def stop(self) -> None:
        self.stage.close()


def performer_here(
    name: str, port: str = ARM, silence_ms: float = PATIENT_SILENCE_MS
) -> tuple[PerformerHere, str]:
    """A performer in this process, waiting for a show: (it, its endpoint)."""
    performer = PerformerHere(name, port, silence_ms)
    return performer, performer.endpoint


def every_part_ended(process: Transcript) -> bool:
    """Whether a performer has said the last line of each part it took on this page."""
    lines = process.lines
    ended = sum(any(end in line for end in PART_ENDS) for line in lines)
    return sum(STAGED in line for line in lines) == ended


class Troupe:
    """Patient performers on ARM in this process, each started the first time a test asks for
    it by name and kept for the next. Each test reads only what they say during it (a page
    turned at its start); at its end each has said the last line of every part it took, so none
    of it lands on the next test's page. After a failed test they are stopped: the next starts
    its own."""

    def __init__(self) -> None:
        self.running: dict[str, tuple[PerformerHere, str]] = {}

    def begin_test(self) -> dict[str, tuple[PerformerHere, str]]:
        """A new page for each; the test's own performers (by name, filled by ``start``)."""
        for process, _ in self.running.values():
            process.turn_page()
        return {}

    def start(self, started: dict[str, tuple[PerformerHere, str]], *names: str) -> list[str]:
        """The endpoints of ``names``, in order, each waiting for a show; noted in ``started``."""
        starting = [name for name in names if name not in self.running]
        self.running.update((name, performer_here(name)) for name in starting)
        started.update((name, self.running[name]) for name in names)
        return [self.running[name][1] for name in names]

    def end_test(self, started: dict[str, tuple[PerformerHere, str]], failed: bool) -> None:
        """Wait for the end of every part ``started`` took; stop all after a failure."""
        deadline = time.monotonic() + PROCESS_WAIT_S
        unfinished = list(started)
        while unfinished and time.monotonic() < deadline:
            unfinished = [name for name in unfinished if not every_part_ended(started[name][0])]
            time.sleep(0.02)
        gone = any(process.ended() for process, _ in self.running.values())
        if unfinished or failed or gone:
            self.stop()
        assert not unfinished, f"{unfinished} never said the end of a part they took"

    def stop(self) -> None:
        for process, _ in self.running.values():
            process.stop()
        self.running.clear()
