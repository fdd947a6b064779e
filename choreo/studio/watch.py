"""Noticing saves: the files a motion uses, polled for a new size or modification time.

Polling (not inotify) works the same on every OS and every editor's way of saving (in place,
or a new file renamed over the old); a few stat calls every POLL_S cost nothing."""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

log = logging.getLogger(__name__)

POLL_S = 0.05
Stamp = tuple[int, int] | None  # (mtime_ns, size), None while the file is missing


def stamp(path: Path) -> Stamp:
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_mtime_ns, status.st_size


class FileWatcher:
    """Calls ``on_change`` (from its own thread) once the files of ``files()`` change; the
    set of files is asked again after each change (a save can add an include)."""

    def __init__(self, files: Callable[[], Iterable[Path]], on_change: Callable[[], None]):
        self._files = files
        self._on_change = on_change
        self._stop = threading.Event()
        self._stamps: dict[Path, Stamp] = {}
        self._polling = threading.Lock()  # a poll, or the studio's write: one at a time
        self._thread = threading.Thread(target=self._run, name="studio-watch", daemon=True)

    def _read(self) -> dict[Path, Stamp]:
        return {path: stamp(path) for path in self._files()}

    def start(self) -> None:
        self._stamps = self._read()
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    @contextlib.contextmanager
    def writing(self) -> Iterator[None]:
        """Around the studio's own writes: what it wrote is known when the block ends, and no
        poll falls between a write and then (it would reload the studio's write a second time,
        simulating it again, after the studio's own reload)."""
        with self._polling:
            yield
            self._stamps = self._read()

    def _saved(self, now: dict[Path, Stamp]) -> bool:
        """Whether a file watched before has changed. A file only the last reload brought in
        (an include, a song) was read by it: no save, or a reload of the same bytes would
        follow every change of the set of files (and refuse the page's next edit as made on
        an older reload)."""
        return any(path in self._stamps and self._stamps[path] != at for path, at in now.items())

    def _run(self) -> None:
        while not self._stop.wait(POLL_S):
            with self._polling:
                now = self._read()
                saved = self._saved(now)
                # stamps from before the reload: a save during it is seen on the next poll
                self._stamps = now
            if saved:
                try:
                    self._on_change()
                except Exception:  # noqa: BLE001  a bug must not stop the studio following saves
                    log.exception("reloading after a save failed")
