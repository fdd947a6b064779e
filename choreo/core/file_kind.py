"""What sits at a path that should be a file, in words: a folder, a FIFO or a device given where
a file belongs is called what it is, not "missing" (and a FIFO is never opened: reading one
blocks until some other program writes to it)."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path


def not_a_file(path: str | os.PathLike) -> str | None:
    """``"a folder"``, ``"a FIFO (named pipe)"``, ``"a device"``, ``"a socket"`` or ``"a loop of
    symbolic links"`` for a path that exists but is not a regular file (symlinks followed);
    ``None`` for a regular file or when nothing is there (the caller says "does not exist" in
    its own terms)."""
    try:
        mode = os.stat(path).st_mode
    except OSError as error:
        return "a loop of symbolic links" if error.errno == errno.ELOOP else None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "a socket"


def os_error_text(error: OSError) -> str:
    """An ``OSError`` in one plain phrase: ``dir.yaml: is a directory`` rather than
    ``[Errno 21] Is a directory: 'dir.yaml'``."""
    reason = error.strerror or str(error)
    reason = reason[:1].lower() + reason[1:]
    return f"{Path(error.filename)}: {reason}" if error.filename is not None else reason
