"""Debian packages the suite needs from the machine, installed as root where apt-get exists."""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Callable, Sequence

TIMEOUT_S = 900  # a slow mirror; a hang still ends


def apt_get_install(packages: Sequence[str], what: str, say: Callable[[str], None]) -> bool:
    """Install ``packages`` (``what`` they are, for ``say``); False where this cannot be done
    (no apt-get, not root) or did not succeed."""
    if shutil.which("apt-get") is None or os.geteuid() != 0:
        return False
    say(f"installing {what} (apt-get install {' '.join(packages)})")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for argv in (
        ["apt-get", "update", "-qq"],
        ["apt-get", "install", "-y", "-qq", "--no-install-recommends", *packages],
    ):
        try:
            done = subprocess.run(argv, env=env, capture_output=True, timeout=TIMEOUT_S)
        except (OSError, subprocess.TimeoutExpired):
            return False
        if done.returncode != 0:
            return False
    return True
