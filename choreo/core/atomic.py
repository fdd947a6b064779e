"""Writing files so that readers never see half of one and a crash loses nothing once written."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from choreo.errors import ChoreoError


@contextlib.contextmanager
def atomic_output(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it replaces ``path`` only when the block
    finishes without an exception (Ctrl-C included), so readers never see a half-written file
    and a good old one is never lost. The temporary ends in ``path``'s suffix, for writers that
    choose a format by it. The new file gets the permissions of any new file (0666 less the
    umask), not mkstemp's 0600. The data and the new name are flushed to disk before returning
    (a crash right after loses nothing)."""
    path = Path(path)
    check_writable(path)
    handle, temporary = tempfile.mkstemp(
        prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent
    )
    os.close(handle)
    try:
        yield Path(temporary)
        with open(temporary, "rb") as written:
            os.fsync(written.fileno())
        os.chmod(temporary, 0o666 & ~current_umask())
        os.replace(temporary, path)
        fsync_directory(path.parent)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)


def check_writable(path: Path, *, overwrite: bool = True) -> None:
    """``ChoreoError`` if ``path`` cannot be written: it is a folder, its folder is missing or
    not writable, or (without ``overwrite``) it exists. Commands call it before their work, so
    nothing is computed for an output that would fail at the end."""
    path = Path(path)
    if path.is_dir():
        raise ChoreoError(f"cannot write {path}: it is a folder")
    if not path.parent.is_dir():
        raise ChoreoError(f"cannot write {path}: the folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise ChoreoError(f"cannot write {path}: the folder {path.parent} is not writable")
    if not overwrite and path.exists():
        raise ChoreoError.naming(
            "overwrite", f"{path} exists: choose another file, or allow replacing it ({{option}})"
        )


def write_text_atomically(path: Path, text: str) -> None:
    with atomic_output(path) as temporary:
        temporary.write_text(text, encoding="utf-8")


def current_umask() -> int:
    mask = os.umask(0o022)  # the only way to read it is to set it: put it straight back
    os.umask(mask)
    return mask


def fsync_directory(folder: Path) -> None:
    """Make a new or renamed file's name durable."""
    if os.name != "posix":
        return  # Windows cannot open a folder for fsync; NTFS journals its metadata
    handle = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)
