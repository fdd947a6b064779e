"""choreo studio: how fast a save reaches the page, how fast the server follows a scrubbing
page, and what memory a long session of edits leaves.

  save -> page   a motion file is rewritten (one keyframe more or less) and the time until the
                 page in Chromium shows the new keyframe count is measured: the studio's
                 polling, loading, planning, simulating and the page's update together.
                 For an arm6 motion of 30 s and one of 5 minutes. Goal: <= 1 s for 30 s.
  scrub          scrub requests the server handles per second (pose the robot, send the scene).
  memory         the process's resident memory after a 10-minute session of edits (a save every
                 6 s: 100 saves), and before it.

Needs the studio extra, Playwright and Debian's chromium (as tests/test_studio_browser.py).
Run: python benchmarks/bench_studio.py
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

from choreo.studio.address import Address
from choreo.studio.server import Studio

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_studio_browser import CHROMIUM, CHROMIUM_ARGS, free_port  # noqa: E402

SAVES = 5
SESSION_SAVES = 100  # 10 minutes, a save every 6 s
SCRUB_S = 3.0
GOAL_S = 1.0


def motion_text(duration_s: int, extra: bool) -> str:
    """arm6 swaying through a keyframe a second (one more at the end when ``extra``)."""
    rng = np.random.default_rng(7)
    lines = ["robot: arm6", "keyframes:", "  - pose: home"]
    for t in range(1, duration_s + 1 + int(extra)):
        yaw, shoulder, elbow = rng.uniform(-30, 30), rng.uniform(-20, 20), rng.uniform(0, 40)
        lines.append(
            f"  - pose: {{base_yaw: {yaw:.1f}, shoulder: {shoulder:.1f}, elbow: {elbow:.1f}}}"
        )
        lines.append(f"    t: {t}")
    return "\n".join(lines) + "\n"


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def save_to_page(browser, folder: Path, duration_s: int) -> tuple[list[float], list[float]]:
    """Per save: (seconds until the studio has reloaded, seconds until the page shows it)."""
    path = folder / f"motion_{duration_s}s.yaml"
    path.write_text(motion_text(duration_s, extra=False))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    page = browser.new_page(viewport={"width": 1100, "height": 720})
    try:
        page.goto(studio.address.url)
        page.wait_for_selector(f"text={duration_s + 1} keyframes", timeout=60_000)
        reloaded, shown = [], []
        for i in range(SAVES):
            extra = i % 2 == 0
            keyframes = duration_s + 1 + int(extra)
            version = studio.session.version
            start = time.perf_counter()
            path.write_text(motion_text(duration_s, extra))
            while studio.session.version == version or studio.session.plan is None:
                time.sleep(0.005)
            reloaded.append(time.perf_counter() - start)
            page.wait_for_selector(f"text={keyframes} keyframes", timeout=60_000)
            shown.append(time.perf_counter() - start)
        return reloaded, shown
    finally:
        page.close()
        studio.close()


def scrub_rate(folder: Path) -> float:
    path = folder / "scrub.yaml"
    path.write_text(motion_text(30, extra=False))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    try:
        count, start = 0, time.perf_counter()
        while time.perf_counter() - start < SCRUB_S:
            studio.scrub((count * 0.37) % 30)
            count += 1
        return count / (time.perf_counter() - start)
    finally:
        studio.close()


def session_memory(folder: Path) -> tuple[float, float]:
    path = folder / "session.yaml"
    path.write_text(motion_text(30, extra=False))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    try:
        before = rss_mb()
        for i in range(SESSION_SAVES):
            version = studio.session.version
            path.write_text(motion_text(30, extra=i % 2 == 0))
            while studio.session.version == version:
                time.sleep(0.01)
        return before, rss_mb()
    finally:
        studio.close()


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as playwright:
        folder = Path(tmp)
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        for duration_s in (30, 300):
            reloaded, shown = save_to_page(browser, folder, duration_s)
            goal = f" (goal <= {GOAL_S:g} s)" if duration_s == 30 else ""
            print(
                f"{duration_s:>3} s motion, median (max) over {SAVES} saves: save -> reloaded "
                f"{statistics.median(reloaded):.2f} s ({max(reloaded):.2f}), save -> page "
                f"{statistics.median(shown):.2f} s ({max(shown):.2f}){goal}"
            )
        browser.close()
        print(f"scrub: {scrub_rate(folder):.0f} requests/s handled by the server")
        before, after = session_memory(folder)
        print(
            f"memory: {before:.0f} MB before, {after:.0f} MB after {SESSION_SAVES} saves "
            "(a 10-minute session, a save every 6 s)"
        )


if __name__ == "__main__":
    main()
