"""The studio's journal: every write the page made to the motion file, to undo and redo byte
for byte, and never over an edit made outside the page since."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from choreo.core.atomic import atomic_output
from choreo.errors import ChoreoError


class JournalRefused(ChoreoError):
    """Nothing to undo or redo, or the file is no longer what the studio wrote: the message
    says which; nothing was written."""


@dataclass(frozen=True)
class Step:
    """One write: the file's bytes before and after it, and what it did ("added a keyframe")."""

    before: bytes
    after: bytes
    what: str


class Journal:
    """The writes made to ``path``, newest last; an undone write can be redone until the next
    write."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self._done: list[Step] = []
        self._undone: list[Step] = []

    @property
    def can_undo(self) -> bool:
        return bool(self._done)

    @property
    def can_redo(self) -> bool:
        return bool(self._undone)

    def record(self, before: bytes, after: bytes, what: str) -> None:
        """A write the studio just made (a new write forgets what was undone)."""
        self._done.append(Step(before, after, what))
        self._undone.clear()

    @contextlib.contextmanager
    def one_step(self, what: str) -> Iterator[None]:
        """The writes recorded inside are one step, ``what`` (several keyframes moved, deleted
        or pasted: undone and redone together). Only writes that follow one another are
        joined: a write made over an outside edit starts a step of its own, so that no undo
        takes the outside edit away."""
        mark = len(self._done)
        try:
            yield
        finally:
            joined: list[Step] = []
            for step in self._done[mark:]:
                if joined and joined[-1].after == step.before:
                    joined[-1] = Step(joined[-1].before, step.after, what)
                else:
                    joined.append(step)
            self._done[mark:] = joined

    def undo(self) -> Step:
        """Put the file back as it was before the last write; ``JournalRefused`` if there is
        none, or the file changed since it was written."""
        if not self._done:
            raise JournalRefused("nothing to undo: the page has written nothing yet")
        step = self._done[-1]
        self._restore(step.after, step.before, f"undo {step.what}")
        self._undone.append(self._done.pop())
        return step

    def redo(self) -> Step:
        """Make the last undone write again; ``JournalRefused`` as ``undo``."""
        if not self._undone:
            raise JournalRefused("nothing to redo: no write was undone since the last one")
        step = self._undone[-1]
        self._restore(step.before, step.after, f"redo {step.what}")
        self._done.append(self._undone.pop())
        return step

    def _restore(self, expected: bytes, wanted: bytes, what: str) -> None:
        try:
            now = self.path.read_bytes()
        except OSError as error:
            raise JournalRefused(f"cannot {what}: {self.path}: {error.strerror or error}") from None
        if now != expected:
            raise JournalRefused(
                f"cannot {what}: {self.path} changed on disk since the studio wrote it; the "
                "outside edit stays (undo it in the editor that made it)"
            )
        try:
            with atomic_output(self.path) as temporary:
                temporary.write_bytes(wanted)
        except OSError as error:
            raise JournalRefused(f"cannot {what}: {self.path}: {error.strerror or error}") from None
