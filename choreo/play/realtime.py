"""Real-time priority for the player, where the system permits it.

On a busy computer the scheduler may run something else when a START is due: beside two CPU hogs
on two cores START lateness p99 grows from 0.04 ms to a few ms (``benchmarks/bench_player.py``).
A SCHED_FIFO thread runs as soon as it wakes, ahead of every normal process, and locked memory
cannot be paged out under it. Linux permits both to root, to a program with the capabilities
CAP_SYS_NICE (and CAP_IPC_LOCK), or to a user with an ``rtprio`` limit in
``/etc/security/limits.conf``; elsewhere the player keeps its normal priority and says how to
allow it. Only the calling thread is raised (the player's), and only for the play: the previous
policy comes back afterwards. The kernel's real-time throttling (95 % of each second by default)
keeps a runaway real-time thread from freezing the machine.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import getpass
import os
import resource
import shlex
import sys
from collections.abc import Iterator
from dataclasses import dataclass

PLAY_PRIORITY = 50  # SCHED_FIFO 1-99: above normal work, below the kernel's own (IRQ threads)
MCL_CURRENT, MCL_FUTURE = 1, 2  # <sys/mman.h> on Linux


@dataclass(frozen=True)
class Scheduling:
    """What the player ran with."""

    policy: str  # "SCHED_FIFO", "SCHED_OTHER", ...
    priority: int  # the real-time priority (0 for the normal policies)
    memory_locked: bool
    asked: bool = True  # False: not asked (a virtual clock needs no priority, or not wanted)

    @property
    def realtime(self) -> bool:
        return self.policy in ("SCHED_FIFO", "SCHED_RR")

    def describe(self) -> str:
        """One line: which priority the play runs with, and how to allow it where it could not."""
        if not self.asked:
            return "scheduling: normal priority (real-time priority not asked)"
        locked = "memory locked" if self.memory_locked else "memory not locked"
        if self.realtime:
            return f"scheduling: real-time priority ({self.policy} {self.priority}), {locked}"
        return (
            f"scheduling: normal priority ({self.policy}): real-time priority is not permitted "
            f"here, so a busy computer can make STARTs late; {how_to_allow()}"
        )


def how_to_allow() -> str:
    """How to permit real-time priority, naming this user and the interpreter that runs choreo
    (file capabilities belong to the real file, not to a virtualenv's link to it)."""
    python = shlex.quote(os.path.realpath(sys.executable))
    user = _user_name()
    return (
        "to allow it, run as root, or give this Python the capabilities "
        f"(`sudo setcap cap_sys_nice,cap_ipc_lock+ep {python}`), or give your user an rtprio "
        f"limit (`{user} - rtprio {PLAY_PRIORITY}` and `{user} - memlock unlimited` in "
        "/etc/security/limits.conf, then log in again)"
    )


def _user_name() -> str:
    """This user's name as limits.conf takes it (``@name`` would be a group)."""
    try:
        return getpass.getuser()
    except (KeyError, OSError):  # a uid without a name (a container): limits.conf takes uid:uid
        return f"{os.getuid()}:{os.getuid()}"


NOT_ASKED = Scheduling("SCHED_OTHER", 0, False, asked=False)


@contextlib.contextmanager
def realtime_priority(priority: int = PLAY_PRIORITY) -> Iterator[Scheduling]:
    """SCHED_FIFO at ``priority`` and locked memory where permitted, for the ``with`` block;
    yields what was got. Never raises for want of permission."""
    previous = (os.sched_getscheduler(0), os.sched_getparam(0))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        raised = True
    except OSError:  # EPERM: not permitted
        raised = False
    locked = _lock_memory()
    try:
        yield _current(locked)
    finally:
        if locked:
            _libc().munlockall()
        if raised:
            os.sched_setscheduler(0, *previous)


def _current(memory_locked: bool) -> Scheduling:
    policy = os.sched_getscheduler(0)
    names = {
        getattr(os, name): name
        for name in ("SCHED_OTHER", "SCHED_FIFO", "SCHED_RR", "SCHED_BATCH", "SCHED_IDLE")
        if hasattr(os, name)
    }
    return Scheduling(
        names.get(policy, str(policy)), os.sched_getparam(0).sched_priority, memory_locked
    )


def _lock_memory() -> bool:
    """Lock the process's pages in memory. Future pages too only where the locked-memory limit
    cannot be reached (root, or an unlimited limit): under a limit a later allocation would fail
    once it is reached."""
    soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    unlimited = os.geteuid() == 0 or soft == resource.RLIM_INFINITY
    flags = MCL_CURRENT | (MCL_FUTURE if unlimited else 0)
    return _libc().mlockall(flags) == 0


def _libc():
    return ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
