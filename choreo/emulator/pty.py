"""The emulator on a pseudo-terminal, so any program can open it like ``/dev/ttyUSB0``.

The slave side is put in raw mode and named by a symlink; the bridge reads the host's bytes from
the master as they come and writes each byte that reaches the host (replies, echo) at the moment it
arrives on the emulated wire. A pty has no baud rate, so any setting works. The emulator should run
on a ``RealClock``.
"""

from __future__ import annotations

import fcntl
import logging
import math
import os
import re
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
PTY_DEVICE = re.compile(r"/dev/pts/\d+")  # what a link of this bridge points to


class PtyBridge:
    """Serves ``emulator`` on a new pty; ``link_path`` becomes a symlink to its slave device.

    A link left at ``link_path`` by an emulator that is gone (killed before it could remove it)
    is replaced, and ``replaced_target`` says where it pointed; anything else there is refused.
    """

    def __init__(self, emulator: BusEmulator, link_path: str | os.PathLike):
        self.emulator = emulator
        self.link_path = Path(link_path)
        self.replaced_target: str | None = None
        self._stopping = False
        self._master, self._slave = os.openpty()
        self._wake_read, self._wake_write = os.pipe()
        try:
            # How another bridge tells this pty in use: a POSIX record lock, held while the
            # process lives (and until it closes any descriptor of the pty, so a client in the
            # same process ends it). Not flock: clients take that one (pyserial's exclusive).
            fcntl.lockf(self._slave, fcntl.LOCK_EX | fcntl.LOCK_NB)
            tty.setraw(self._slave)
            os.set_blocking(self._master, False)
            os.set_blocking(self._wake_write, False)
            self.slave_name = os.ttyname(self._slave)
            try:
                try:
                    os.symlink(self.slave_name, self.link_path)
                except FileExistsError:
                    self.replaced_target = self._remove_stale_link()
                    os.symlink(self.slave_name, self.link_path)
            except FileExistsError:  # made again meanwhile: someone else's
                raise self._exists() from None
            except OSError as error:
                raise ChoreoError(f"cannot create {self.link_path}: {error.strerror}") from error
        except BaseException:
            self._close_fds()
            raise

    def _remove_stale_link(self) -> str:
        """Remove a link to a pty no emulator serves any more, returning its target: a pty
        device that is gone, or that no bridge holds (a bridge locks its pty while it lives):
        the kernel hands the number of a dead emulator's pty to the next one opened, often this
        bridge's own. A link to a pty a bridge holds, or anything but such a link, is refused."""
        try:
            target = os.readlink(self.link_path)
        except OSError:  # not a symlink: a file or folder someone made
            raise self._exists() from None
        if not PTY_DEVICE.fullmatch(target):
            raise self._exists()
        if target != self.slave_name and _held_by_a_bridge(target):
            raise ChoreoError.naming(
                "link_path",
                f"{self.link_path} already links to {target}, which another emulator serves; "
                "stop that one, or choose another path ({option})",
            )
        self.link_path.unlink(missing_ok=True)
        return target

    def _exists(self) -> ChoreoError:
        return ChoreoError.naming(
            "link_path",
            f"{self.link_path} already exists; remove it or choose another path ({{option}})",
        )

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


def _held_by_a_bridge(device: str) -> bool:
    """Whether a live :class:`PtyBridge` holds the pty ``device`` (one that cannot be opened to
    tell, e.g. another user's terminal, counts as held: it is not replaced)."""
    try:
        fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except FileNotFoundError:
        return False
    except OSError:
        return True
    try:
        fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # locked (EAGAIN): a bridge holds it
        return True
    finally:
        os.close(fd)  # and with it the lock just taken
    return False
