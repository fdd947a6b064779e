"""choreo studio: how fast a save reaches the page, how fast the server follows a scrubbing
page, and what memory a long session of edits leaves.

  save -> page   a motion file is saved (written aside and renamed over, as editors do) with
                 one keyframe changed, and the page in Chromium times, as its text changes,
                 when it shows the new plan ("reload N simulating", or its physics if that
                 came as fast: the studio's polling, loading, planning and the page's update)
                 and when it shows the new plan's physics ("reload N simulated": the
                 simulation and the page's second update).
                 The keyframe changed is the one halfway (the physics before it is reused from
                 the last simulation) or the first one (the worst case: all of it simulated
                 again). For an arm6 motion of 30 s and one of 5 minutes. Goals (page
                 showing the physics, median): <= 0.6 s for 30 s, <= 2 s for 5 minutes.
                 (The page's own clock: Playwright's waiting polls, up to 1 s late.)
  scrub          scrub requests the server handles per second (pose the robot, send the scene).
  drag           a drag's move handled by the server (solved, posed, sent to the page): an arm's
                 site handle, a tonypi hand, a joint's ring; goal <= 100 ms on screen (the
                 browser's drawing, a frame, comes on top).
  memory         the process's resident memory after a 10-minute session of edits (a save every
                 6 s: 100 saves), and before it.
  timeline       the timeline's redraw in Chromium (software rendering) of a motion of 1,000
                 keyframes, all in view, timed by the page around its own drawing: all of it
                 (a zoom, a pan, an edit), and a frame while playing (the layer under the
                 playhead copied); goal <= 16 ms.
  audio drift    the song against the timeline while playing 60 s: the page's song position
                 minus where its timeline's clock says the song should be, every frame; goal
                 within 20 ms.

Needs the studio extra, Playwright and Debian's chromium (as tests/studio/test_studio_browser.py).
Run: python benchmarks/bench_studio.py [timeline|drag|save]   (only the timeline's, the drags'
or the saves' figures)
"""

from __future__ import annotations

import io
import os
import statistics
import sys
import tempfile
import time
import wave
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

from choreo.studio.address import Address
from choreo.studio.scene import about_x, quaternion_of, rotation_of
from choreo.studio.server import Studio

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "studio"))
from browser import chosen  # noqa: E402
from studio_browser_helpers import free_port  # noqa: E402
from test_timeline_page_browser import Timeline, many_keyframes  # noqa: E402  (tests/studio)

SAVES = 5
SESSION_SAVES = 100  # 10 minutes, a save every 6 s
SCRUB_S = 3.0
GOALS_S = {30: 0.6, 300: 2.0}  # save -> page with physics, median
DRAGS = 20
DRAG_GOAL_MS = 100
REDRAWS = 60
REDRAW_GOAL_MS = 16
PLAY_S = 60.0
DRIFT_GOAL_MS = 20


def motion_text(duration_s: int, changed_s: int | None = None) -> str:
    """arm6 swaying through a keyframe a second; the one at ``changed_s`` turned 5° further."""
    rng = np.random.default_rng(7)
    lines = ["robot: arm6", "keyframes:", "  - pose: home"]
    for t in range(1, duration_s + 1):
        yaw, shoulder, elbow = rng.uniform(-30, 30), rng.uniform(-20, 20), rng.uniform(0, 40)
        yaw += 5.0 if t == changed_s else 0.0
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


# When the page's text first contains ``want``, by the page's clock (ms since the epoch).
WHEN_SHOWN = """want => new Promise(resolve => {
  const seen = new MutationObserver(() => {
    if (document.body.innerText.includes(want)) {
      seen.disconnect();
      resolve(performance.timeOrigin + performance.now());
    }
  });
  seen.observe(document.body, {subtree: true, childList: true, characterData: true});
})"""


def save(path: Path, text: str) -> None:
    """As an editor saves: the whole file written aside, then renamed over the old one."""
    aside = path.with_name(f".{path.name}.saving")
    aside.write_text(text)
    os.replace(aside, path)


def save_to_page(browser, folder: Path, duration_s: int, changed_s: int) -> dict[str, list[float]]:
    """Per save (the keyframe at ``changed_s`` changed, then changed back), seconds until: the
    studio has planned it, the page shows the plan, the studio has simulated it, the page shows
    the physics."""
    path = folder / f"motion_{duration_s}s.yaml"
    save(path, motion_text(duration_s))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    page = browser.new_page(viewport={"width": 1100, "height": 720})
    times: dict[str, list[float]] = {"planned": [], "plan shown": [], "simulated": [], "shown": []}
    try:
        page.goto(studio.address.url)
        page.wait_for_selector("text=reload 1 simulated", timeout=60_000)
        for i in range(SAVES):
            version = studio.session.version + 1
            page.evaluate(
                # the plan is on the page ("reload N planned: …; simulating…"), or with its
                # physics if that came in the same message ("reload N simulated")
                f"() => {{ window.planShown = Promise.race([({WHEN_SHOWN})('reload {version} "
                f"planned'), ({WHEN_SHOWN})('reload {version} simulated')]); "
                f"window.shown = ({WHEN_SHOWN})('reload {version} simulated'); }}"
            )
            start = time.time()
            save(path, motion_text(duration_s, changed_s if i % 2 == 0 else None))
            planned = simulated = None
            while simulated is None:
                if planned is None and studio.session.version >= version:
                    planned = time.time()
                plan = studio.session.plan  # after the version: the new plan
                if planned is not None and plan is not None and plan.physics is not None:
                    simulated = time.time()
                time.sleep(0.002)
            page.wait_for_selector(f"text=reload {version} simulated", timeout=60_000)
            times["planned"].append(planned - start)
            times["plan shown"].append(page.evaluate("() => window.planShown") / 1000 - start)
            times["simulated"].append(simulated - start)
            times["shown"].append(page.evaluate("() => window.shown") / 1000 - start)
        return times
    finally:
        page.close()
        studio.close()


def scrub_rate(folder: Path) -> float:
    path = folder / "scrub.yaml"
    path.write_text(motion_text(30))
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


# tonypi standing, then squatting: its hands and feet have handles
TONYPI = "robot: tonypi\nkeyframes:\n  - pose: home\n  - pose: squat\n    t: 1.5\n"


def drag_times(folder: Path) -> dict[str, list[float]]:
    """Milliseconds per drag move, as viser hands them to the studio: arm6's tool site moved
    about, tonypi's left hand moved about, arm6's elbow ring turned."""
    arm = folder / "drag_arm.yaml"
    arm.write_text(motion_text(30))
    humanoid = folder / "drag_tonypi.yaml"
    humanoid.write_text(TONYPI)
    figures: dict[str, list[float]] = {"arm6 site": [], "tonypi hand": [], "arm6 joint ring": []}
    for path, site, name in ((arm, "tool", "arm6 site"), (humanoid, "left_hand", "tonypi hand")):
        studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
        studio.start()
        try:
            assert studio.view is not None
            start, _ = studio.view.handle_pose(site)
            for i in range(DRAGS):  # a small circle: each move a few millimetres
                angle = 2 * np.pi * i / DRAGS
                target = start + 0.01 * np.array([np.cos(angle) - 1, np.sin(angle), 0.0])
                began = time.perf_counter()
                studio.drag_site(site, target)
                figures[name].append((time.perf_counter() - began) * 1000)
            if name == "arm6 site":
                elbow = studio.view.robot.joint_names.index("elbow")
                studio.scrub(1.0)
                studio.view.add_joint_handle(elbow, lambda *_: None)
                _, wxyz = studio.view.handle_pose("/joint")
                for i in range(DRAGS):
                    turned = quaternion_of(rotation_of(wxyz) @ about_x(np.radians(i % 10)))
                    began = time.perf_counter()
                    studio.turn_joint("elbow", turned)
                    figures["arm6 joint ring"].append((time.perf_counter() - began) * 1000)
        finally:
            studio.close()
    return figures


def session_memory(folder: Path) -> tuple[float, float]:
    path = folder / "session.yaml"
    path.write_text(motion_text(30))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    try:
        before = rss_mb()
        for i in range(SESSION_SAVES):
            version = studio.session.version
            save(path, motion_text(30, 15 if i % 2 == 0 else None))
            while studio.session.version == version or studio.session.plan.physics is None:
                time.sleep(0.01)
        return before, rss_mb()
    finally:
        studio.close()


def timeline_redraw(browser, folder: Path) -> tuple[list[float], list[float], dict[str, float]]:
    """Milliseconds per redraw of the timeline with 1,000 keyframes in view: all of it (as a
    zoom, a pan or an edit makes it), and a frame while playing (the playhead moved); and the
    parts of the last full one."""
    path = folder / "thousand.yaml"
    path.write_text(many_keyframes(1000, 0.3))
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    page = browser.new_page(viewport={"width": 1280, "height": 820})
    try:
        page.goto(studio.address.url)
        timeline = Timeline(page, studio)
        timeline.frame.wait_for_function(
            "() => window.choreoTimeline.state && window.choreoTimeline.state.keyframes.length"
            " === 1000",
            timeout=120_000,
        )
        timeline.press("0")  # all of it in view
        full = [timeline.js("tl.redraw(true)") for _ in range(REDRAWS)]
        parts = timeline.js("tl.partMs()")
        playing = [timeline.js("tl.redraw(false)") for _ in range(REDRAWS)]
        return full, playing, parts
    finally:
        page.close()
        studio.close()


def click_track(path: Path, duration_s: float, bpm: float, rate_hz: int = 22050) -> None:
    """A WAV of a click on every beat, ``duration_s`` long."""
    samples = np.zeros(int(duration_s * rate_hz), dtype=np.int16)
    click = (np.sin(np.arange(400) * 2 * np.pi * 1000 / rate_hz) * 20000).astype(np.int16)
    for beat in np.arange(0, duration_s, 60 / bpm):
        start = int(beat * rate_hz)
        samples[start : start + len(click)] = click[: len(samples) - start]
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate_hz)
        out.writeframes(samples.tobytes())
    path.write_bytes(buffer.getvalue())


def audio_drift(browser, folder: Path) -> list[float]:
    """The song's position minus the timeline's, in ms, every frame of PLAY_S s of playing."""
    click_track(folder / "clicks.wav", PLAY_S + 20, 120)
    lines = ["robot: arm6", "music: {song: clicks.wav, bpm: 120}", "keyframes:", "  - pose: home"]
    for bar in range(2, int(PLAY_S / 2) + 6):
        lines += [f"  - pose: {{base_yaw: {15 if bar % 2 else -15}}}", f"    bar: {bar}"]
    path = folder / "song.yaml"
    path.write_text("\n".join(lines) + "\n")
    studio = Studio(path, Address("127.0.0.1", free_port()), say=lambda line: None)
    studio.start()
    page = browser.new_page(viewport={"width": 1280, "height": 820})
    try:
        page.goto(studio.address.url)
        timeline = Timeline(page, studio)
        timeline.frame.wait_for_function(
            "() => document.getElementById('song').readyState >= 3", timeout=60_000
        )
        timeline.press(" ")
        timeline.frame.wait_for_function("() => window.choreoTimeline.playing")
        timeline.js("tl.clearDrift()")
        page.wait_for_timeout(PLAY_S * 1000)
        drift = timeline.js("tl.drift()")
        timeline.press(" ")
        return [d * 1000 for d in drift]
    finally:
        page.close()
        studio.close()


def print_drags(folder: Path) -> None:
    for what, took in drag_times(folder).items():
        print(
            f"drag: {what}, median (max) of {len(took)} moves: {statistics.median(took):.1f} "
            f"ms ({max(took):.1f}) in the server (goal <= {DRAG_GOAL_MS} ms on screen)"
        )


def print_saves(browser, folder: Path) -> None:
    for duration_s in (30, 300):
        for changed_s, which in ((duration_s // 2, "halfway"), (1, "first")):
            times = save_to_page(browser, folder, duration_s, changed_s)
            goal = f" (goal: shown <= {GOALS_S[duration_s]:g} s)"
            print(
                f"{duration_s:>3} s motion, {which} keyframe changed, median (max) over "
                f"{SAVES} saves{goal}: save -> "
                + ", ".join(
                    f"{what} {statistics.median(t):.2f} s ({max(t):.2f})"
                    for what, t in times.items()
                )
            )


def main() -> None:
    if sys.argv[1:] == ["drag"]:  # only the drags' figures
        with tempfile.TemporaryDirectory() as tmp:
            print_drags(Path(tmp))
        return
    choice = chosen()  # before Playwright starts: finding a browser starts Playwright too
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as playwright:
        folder = Path(tmp)
        browser = choice.launch(playwright)
        if sys.argv[1:] == ["save"]:  # only the saves' figures
            print_saves(browser, folder)
            browser.close()
            return
        redraws, frames, parts = timeline_redraw(browser, folder)
        slowest = ", ".join(
            f"{k} {v:.1f}" for k, v in sorted(parts.items(), key=lambda kv: -kv[1])[:3]
        )
        print(
            f"timeline: redraw with 1,000 keyframes in view, median (max) of {REDRAWS}: "
            f"{statistics.median(redraws):.1f} ms ({max(redraws):.1f}) "
            f"(goal <= {REDRAW_GOAL_MS} ms; slowest parts, ms: {slowest}); a frame while "
            f"playing: {statistics.median(frames):.1f} ms ({max(frames):.1f})"
        )
        drift = np.abs(audio_drift(browser, folder))
        if not len(drift):
            print(f"audio drift: no frame sampled in {PLAY_S:g} s: the song did not play")
        else:
            print(
                f"audio drift: song against the timeline over {PLAY_S:g} s of playing, "
                f"{len(drift)} frames: median {np.median(drift):.1f} ms, 95th percentile "
                f"{np.percentile(drift, 95):.1f} ms, max {drift.max():.1f} ms "
                f"(goal within {DRIFT_GOAL_MS} ms)"
            )
        if sys.argv[1:] == ["timeline"]:  # only the timeline's figures
            browser.close()
            return
        print_saves(browser, folder)
        browser.close()
        print(f"scrub: {scrub_rate(folder):.0f} requests/s handled by the server")
        print_drags(folder)
        before, after = session_memory(folder)
        print(
            f"memory: {before:.0f} MB before, {after:.0f} MB after {SESSION_SAVES} saves "
            "(a 10-minute session, a save every 6 s)"
        )


if __name__ == "__main__":
    main()
