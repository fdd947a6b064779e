"""The emulator on a pseudo-terminal, so any program can open it like ``/dev/ttyUSB0``.

The slave side is put in raw mode and named by a symlink; the bridge reads the host's bytes from
the master as they come and writes each byte that reaches the host (replies, echo) at the moment it
arrives on the emulated wire. A pty has no baud rate, so any setting works. The emulator should run
on a ``RealClock``.
"""

from __future__ import annotations

import logging
import math
import os
import select
import tty
from pathlib import Path

from choreo.emulator.bus_emulator import BusEmulator
from choreo.errors import ChoreoError

logger = logging.getLogger(__name__)

# select() may wake this late; closer than this to a byte's due time we spin instead, so replies
# leave within a few microseconds of their time (the pty benchmark measures round trips).
SPIN_S = 0.0002
READ_CHUNK = 4096


class PtyBridge:
    """Serves ``emulator`` on a new pty; ``link_path`` becomes a symlink to its slave device."""

    def __init__(self, emulator: BusEmulator, link_path: str | os.PathLike):
        self.emulator = emulator
        self.link_path = Path(link_path)
        self._stopping = False
        self._master, self._slave = os.openpty()
        self._wake_read, self._wake_write = os.pipe()
        try:
            tty.setraw(self._slave)
            os.set_blocking(self._master, False)
            os.set_blocking(self._wake_write, False)
            self.slave_name = os.ttyname(self._slave)
            try:
                os.symlink(self.slave_name, self.link_path)
            except FileExistsError:
                raise ChoreoError.naming(
                    "link_path",
                    f"{self.link_path} already exists; remove it or choose another path "
                    "({option})",
                ) from None
            except OSError as error:
                raise ChoreoError(f"cannot create {self.link_path}: {error.strerror}") from error
        except BaseException:
            self._close_fds()
            raise

    def __enter__(self) -> PtyBridge:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def serve_forever(self) -> None:
        """Bridge bytes until :meth:`stop` is called (safe from a signal handler)."""
        emulator = self.emulator
        while not self._stopping:
            self._write_to_host(emulator.take_received())
            wait_s = emulator.next_event_s() - emulator.clock.now()
            timeout: float | None
            if wait_s <= SPIN_S:
                timeout = 0.0  # poll, spinning until the next byte is due
            else:
                timeout = None if math.isinf(wait_s) else wait_s - SPIN_S
            readable, _, _ = select.select([self._master, self._wake_read], [], [], timeout)
            if self._master in readable:
                self._read_from_host()
            if self._wake_read in readable:
                os.read(self._wake_read, READ_CHUNK)

    def stop(self) -> None:
        self._stopping = True
        try:
            os.write(self._wake_write, b"\0")
        except BlockingIOError:
            pass  # the pipe is full of wake-ups already

    def close(self) -> None:
        """Remove the symlink (if it is still ours) and close the pty."""
        if self.link_path.is_symlink() and os.readlink(self.link_path) == self.slave_name:
            self.link_path.unlink()
        self._close_fds()

    def _read_from_host(self) -> None:
        try:
            data = os.read(self._master, READ_CHUNK)
        except BlockingIOError:
            return
        self.emulator.write(data)

    def _write_to_host(self, data: bytes) -> None:
        while data:
            try:
                written = os.write(self._master, data)
            except BlockingIOError:
                # Nobody reads the other side: drop the bytes, like a UART that overruns.
                logger.warning("pty output full: dropped %d bytes", len(data))
                return
            data = data[written:]

    def _close_fds(self) -> None:
        for fd in (self._master, self._slave, self._wake_read, self._wake_write):
            try:
                os.close(fd)
            except OSError:
                pass
