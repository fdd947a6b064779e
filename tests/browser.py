"""The Chromium that the studio's browser tests drive, found or installed once per run.

The README's test command is all the set-up a fresh machine needs, so the browser comes with it:
  1. Playwright's own Chromium, if it is already installed and starts;
  2. Debian's chromium, if it is installed;
  3. Playwright's own, downloaded (``python -m playwright install chromium``);
  4. Debian's, installed with apt-get (as root).
Where none can be had, the run stops with one line that names what to run. The choice travels to
the test workers in ``CHOREO_TEST_BROWSER``: ``playwright`` or the path of a chromium binary.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from apt_packages import apt_get_install
from playwright.sync_api import Browser, Playwright, sync_playwright

ENV = "CHOREO_TEST_BROWSER"
PLAYWRIGHTS_OWN = "playwright"
DEBIAN_CHROMIUM = "/usr/bin/chromium"
# Software GL (no GPU here) and no sandbox (tests may run as root); no background networking, so
# a closed network costs nothing.
ARGS = [
    "--no-sandbox",
    "--use-gl=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
]
INSTALL_TIMEOUT_S = 900
WHAT_TO_RUN = (
    "the studio's browser tests need Chromium and none could be installed here: run "
    "`python -m playwright install --with-deps chromium`, or on Debian/Ubuntu "
    "`sudo apt-get install chromium`, then the tests again"
)


class NoBrowser(Exception):
    """No Chromium could be found or installed; the message says what to run."""


@dataclass(frozen=True)
class Choice:
    """Which Chromium: Playwright's own (``executable`` None) or a binary on the system."""

    executable: str | None

    @property
    def label(self) -> str:
        return PLAYWRIGHTS_OWN if self.executable is None else self.executable

    @classmethod
    def from_label(cls, label: str) -> Choice:
        return cls(None if label == PLAYWRIGHTS_OWN else label)

    def launch(self, playwright: Playwright) -> Browser:
        return playwright.chromium.launch(executable_path=self.executable, args=ARGS)


def chosen() -> Choice:
    """The browser this run uses: as chosen by the run's first process, else chosen now."""
    label = os.environ.get(ENV)
    if label:
        return Choice.from_label(label)
    return provide(say=lambda line: None)


def provide(say: Callable[[str], None]) -> Choice:
    """Find or install a Chromium that starts, export the choice, and return it; ``NoBrowser``
    when there is none. ``say`` hears what is being installed (it takes a while)."""
    choice = _find_or_install(say)
    os.environ[ENV] = choice.label
    return choice


def _find_or_install(say: Callable[[str], None]) -> Choice:
    playwrights_own = Choice(None)
    debian = _debian_chromium()
    found = _first_that_starts([playwrights_own] + ([debian] if debian is not None else []))
    if found is not None:
        return found
    say("installing Playwright's Chromium for the studio's browser tests")
    if _run([sys.executable, "-m", "playwright", "install", "chromium"]) and _starts(
        playwrights_own
    ):
        return playwrights_own
    if apt_get_install(["chromium"], "Debian's chromium for the studio's browser tests", say):
        debian = _debian_chromium()
        if debian is not None and _starts(debian):
            return debian
    raise NoBrowser(WHAT_TO_RUN)


def _debian_chromium() -> Choice | None:
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return Choice(found)
    return Choice(DEBIAN_CHROMIUM) if Path(DEBIAN_CHROMIUM).is_file() else None


def _starts(choice: Choice) -> bool:
    """Whether the browser starts headless here (it may be missing, or lack system libraries)."""
    return _first_that_starts([choice]) is not None


def _first_that_starts(choices: list[Choice]) -> Choice | None:
    """The first of ``choices`` that starts headless here, tried by one Playwright driver (each
    driver started costs ~0.4 s of CPU and wall, before any test runs). Playwright's own is
    launched only if it is installed: a launch that fails still costs a driver's round trips."""
    try:
        with sync_playwright() as playwright:
            for choice in choices:
                if (
                    choice.executable is None
                    and not Path(playwright.chromium.executable_path).is_file()
                ):
                    continue
                try:
                    choice.launch(playwright).close()
                except Exception:  # Playwright's errors: a missing library, a crash
                    continue
                return choice
    except Exception:  # the driver itself did not start
        return None
    return None


def _run(argv: list[str]) -> bool:
    try:
        done = subprocess.run(argv, capture_output=True, timeout=INSTALL_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0
