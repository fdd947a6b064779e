"""A FIFO for tests of code that must never open one: if the code under test does open it (the
defect), it reads end-of-file at once instead of blocking the test for ever."""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def fifo_that_never_blocks(path: Path) -> Iterator[Path]:
    os.mkfifo(path)
    writer = threading.Thread(target=lambda: open(path, "wb").close(), daemon=True)
    writer.start()  # waits in open() until a reader comes
    try:
        yield path
    finally:
        while writer.is_alive():  # nobody read it: be the reader that lets the writer go
            os.close(os.open(path, os.O_RDONLY | os.O_NONBLOCK))
            writer.join(0.05)
