"""The studio's timeline page driven in Chromium: diamonds clicked, dragged, boxed,
copied and pasted change the file as they should, the keys do what the README's table says,
findings are marks that name their keyframe, and every mark and keyframe is drawn.

One studio and one page serve the browser tests; each test writes the motion it needs into the
studio's file and waits for the page to show it. The page is the timeline's own, as large as
viser's page frames it: these tests are about the timeline, and viser's 3D view beside it would
cost a software-rendering Chromium seconds to load and a quarter of a second for each change the
studio draws in it (more than half of this file's CPU, Chromium's included).
test_studio_browser.py drives the timeline in viser's page: framed there on the one address, and
keys passed to it from the 3D view.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import studio_browser_helpers as helpers
from studio_browser_helpers import free_port

from choreo.core.atomic import write_text_atomically
from choreo.motion.motion_file import load_motion
from choreo.studio.address import Address
from choreo.studio.server import Studio
from choreo.studio.session import make_plan
from choreo.studio.timeline_server import TIMELINE_HEIGHT

DATA = Path(__file__).parent.parent / "data" / "studio"
WAVE = DATA / "wave.yaml"
BEAT_S = 60 / 112  # wave.yaml dances to 112 BPM, beat 1 at t 0
FRAME_S = 1 / 30
WAIT_S = 60.0  # software rendering on a busy 2-core machine
DIAMOND_RGB = (0x3B, 0x4A, 0x6B)
# the timeline's frame in viser's page of helpers.VIEWPORT: full width, TIMELINE_HEIGHT high
TIMELINE_VIEWPORT = {
    "width": helpers.VIEWPORT["width"],
    "height": round(helpers.VIEWPORT["height"] * float(TIMELINE_HEIGHT.removesuffix("vh")) / 100),
}
SELECTED_RGB = (0xFF, 0x8A, 0x00)

# arm6 pushed past what its servos can do: the simulation finds it touching the floor, stalling
# and lagging on the way to the second keyframe (line 4).
STRAINED = """\
robot: arm6
keyframes:
  - pose: home
  - pose: {shoulder: 90, elbow: 110}
    t: 1.5
  - pose: {shoulder: -90, elbow: -110}
    t: 3.0
  - pose: home
    t: 4.5
"""


def many_keyframes(count: int, step_s: float, swing_deg: float) -> str:
    """arm6 swinging its base to and fro by ``swing_deg`` (0: holding it still), one keyframe
    every ``step_s``. Fitted in the timeline's view, ``count`` keyframes stand as far apart
    whatever ``step_s`` is; the studio simulates the whole motion, so it is kept short."""
    lines = ["robot: arm6", "keyframes:", "  - pose: home"]
    for i in range(1, count):
        lines += [
            f"  - pose: {{base_yaw: {swing_deg if i % 2 else -swing_deg}}}",
            f"    t: {i * step_s:g}",
        ]
    return "\n".join(lines) + "\n"


# --- in Chromium ---------------------------------------------------------------------------------


def wait_for(condition, what: str, timeout_s: float = WAIT_S):
    helpers.wait_for(condition, what, timeout_s)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = tmp_path_factory.mktemp("timeline")
    shutil.copy(WAVE, folder / "wave.yaml")
    shutil.copy(DATA / "groove.ogg", folder / "groove.ogg")
    said: list[str] = []
    studio = Studio(folder / "wave.yaml", Address("127.0.0.1", free_port()), say=said.append)
    studio.said = said  # type: ignore[attr-defined]
    studio.start()
    yield studio
    studio.close()


@pytest.fixture(scope="module")
def browser():
    yield from helpers.launched_browser()


@pytest.fixture(scope="module")
def page(served, browser):
    """The timeline's page, on its own (viser's page frames it from this address)."""
    page = browser.new_page(viewport=TIMELINE_VIEWPORT)
    page.goto(f"{served.address.url}timeline/")
    yield page
    page.close()


class Timeline:
    """The timeline's page: its script's state, and the pointer on its canvas."""

    def __init__(self, page, studio):
        self.page, self.studio = page, studio
        self.frame = page.main_frame
        self.frame.wait_for_function(
            "() => window.choreoTimeline !== undefined", timeout=WAIT_S * 1000
        )
        self.canvas = self.frame.locator("#canvas")

    def js(self, expression: str):
        return self.frame.evaluate(
            f"() => {{ const tl = window.choreoTimeline; return {expression}; }}"
        )

    def shows(self, version: int) -> bool:
        return bool(self.js(f"tl.state !== null && tl.state.version >= {version}"))

    def at(self, t_s: float, y: float) -> tuple[float, float]:
        """Page coordinates of time ``t_s`` on the canvas's row ``y``."""
        box = self.canvas.bounding_box()
        assert box is not None
        return box["x"] + self.js(f"tl.xOf({t_s})"), box["y"] + y

    def key_row(self) -> float:
        return self.js("tl.keyframeY()")

    def click(self, t_s: float, y: float, shift: bool = False) -> None:
        x, y = self.at(t_s, y)
        if shift:
            self.page.keyboard.down("Shift")
        self.page.mouse.click(x, y)
        if shift:
            self.page.keyboard.up("Shift")

    def drag(self, from_t: float, to_t: float, y: float, to_y: float | None = None) -> None:
        x0, y0 = self.at(from_t, y)
        x1, y1 = self.at(to_t, y if to_y is None else to_y)
        mouse = self.page.mouse
        mouse.move(x0, y0)
        mouse.down()
        for step in range(1, 9):
            mouse.move(x0 + (x1 - x0) * step / 8, y0 + (y1 - y0) * step / 8)
        mouse.up()

    def press(self, key: str) -> None:
        self.canvas.focus()
        self.canvas.press(key)

    def pixel(self, t_s: float, y: float, dx: int = 0) -> tuple[int, int, int]:
        """The colour drawn ``dx`` px right of time ``t_s`` on row ``y``, read back from the
        canvas."""
        rgb = self.js(
            f"(() => {{ const c = document.getElementById('canvas'); const r = "
            f"window.devicePixelRatio || 1; const d = c.getContext('2d').getImageData("
            f"Math.round((tl.xOf({t_s}) + {dx}) * r), Math.round({y} * r), 1, 1).data; "
            f"return [d[0], d[1], d[2]]; }})()"
        )
        return tuple(rgb)


def near(rgb: tuple[int, int, int], wanted: tuple[int, int, int]) -> bool:
    """The colour drawn, give or take the smoothing of overlapping edges."""
    return max(abs(a - b) for a, b in zip(rgb, wanted)) <= 12


def undrawn_keyframes(timeline: Timeline) -> list[float]:
    """The keyframes whose diamond is not on the canvas's keyframes lane (those under the red
    playhead aside), read back from what the canvas drew."""
    return timeline.js(
        f"""(() => {{
        const c = document.getElementById('canvas'), r = window.devicePixelRatio || 1;
        const pixels = c.getContext('2d'), y = Math.round(tl.keyframeY() * r);
        const at = tl.xOf(tl.time), want = {list(DIAMOND_RGB)};
        return tl.state.keyframes.map(k => k.t).filter(t => {{
          if (Math.abs(tl.xOf(t) - at) <= 3) return false;
          const d = pixels.getImageData(Math.round(tl.xOf(t) * r), y, 1, 1).data;
          return Math.max(...want.map((v, i) => Math.abs(v - d[i]))) > 12;
        }});
      }})()"""
    )


def write_motion(studio: Studio, text: str) -> int:
    """Put ``text`` in the studio's file; the reload that shows it."""
    path = studio.session.motion_path
    if path.read_text() != text:
        version = studio.session.version
        write_text_atomically(path, text)  # the studio never sees it half written
        wait_for(lambda: studio.session.version > version, "the studio to reload")
    wait_for(
        lambda: studio.session.plan is not None and studio.session.plan.physics is not None,
        "the physics",
    )
    assert studio.session.problems == ()
    return studio.session.version


@pytest.fixture
def timeline(served, page):
    """The timeline showing wave.yaml as written, nothing selected, the playhead at 0."""
    version = write_motion(served, WAVE.read_text())
    line = Timeline(page, served)
    wait_for(lambda: line.shows(version), "the page to show the file")
    line.press("Escape")
    served.scrub(0.0)
    wait_for(lambda: line.js("tl.time") == 0, "the playhead at 0")
    served.said.clear()
    return line


def times_in_file(studio: Studio) -> list[float]:
    return [
        round(t, 4) for t in make_plan(load_motion(studio.session.motion_path)).keyframe_times_s
    ]


def test_clicking_a_diamond_selects_it_and_dragging_it_moves_that_keyframe_in_the_file(timeline):
    studio, row = timeline.studio, timeline.key_row()
    timeline.click(2.0, row)  # keyframe 3
    wait_for(lambda: studio.selected == 2 and studio.time_s == 2.0, "keyframe 3 selected")
    assert timeline.js("tl.selection") == [2]
    assert near(timeline.pixel(2.0, row, dx=3), SELECTED_RGB)  # beside the playhead
    before = studio.session.motion_path.read_text().splitlines()

    version = studio.session.version
    timeline.drag(2.0, 2.3, row)  # snaps to the nearest beat: beat 5 at 4 x 60/112 s
    wait_for(lambda: studio.session.version > version, "the move to be written")
    # written in its neighbours' notation, t: to the millisecond
    assert times_in_file(studio) == pytest.approx([0.0, 1.0, 4 * BEAT_S, 3.0], abs=1e-3)
    after = studio.session.motion_path.read_text().splitlines()
    changed = [i for i, (a, b) in enumerate(zip(before, after)) if a != b]
    assert len(before) == len(after) and changed == [10]  # keyframe 3's time, nothing else
    assert before[10] == "    t: 2.0"


def test_a_box_selects_the_diamonds_inside_it_and_delete_removes_them_from_the_file(timeline):
    studio, row = timeline.studio, timeline.key_row()
    timeline.drag(0.5, 2.5, row - 8, to_y=row + 8)  # keyframes 2 and 3
    wait_for(lambda: timeline.js("tl.selection") == [1, 2], "keyframes 2 and 3 selected")
    timeline.click(3.0, row, shift=True)  # and 4
    wait_for(lambda: timeline.js("tl.selection") == [1, 2, 3], "keyframe 4 added")
    timeline.click(3.0, row, shift=True)  # shift-click again: not 4
    wait_for(lambda: timeline.js("tl.selection") == [1, 2], "keyframe 4 taken out")
    version = studio.session.version
    timeline.press("Delete")
    wait_for(
        lambda: len(times_in_file(studio)) == 2 and studio.session.version > version + 1,
        "two deletions",
    )
    assert times_in_file(studio) == [0.0, 3.0]
    text = studio.session.motion_path.read_text()
    assert "{shoulder: 30, elbow: 40}" not in text and "look left" not in text


def test_copy_and_paste_put_a_keyframe_with_the_same_pose_at_the_playhead(timeline):
    studio, row = timeline.studio, timeline.key_row()
    timeline.click(1.0, row)  # keyframe 2: shoulder 30, elbow 40
    wait_for(lambda: studio.selected == 1, "keyframe 2 selected")
    timeline.press("Control+c")
    studio.scrub(2.5)
    wait_for(lambda: timeline.js("tl.time") == 2.5, "the playhead at 2.5 s")
    version = studio.session.version
    timeline.press("Control+v")
    wait_for(lambda: studio.session.version > version, "the paste to be written")
    plan = make_plan(load_motion(studio.session.motion_path))
    assert [round(t, 3) for t in plan.keyframe_times_s] == [0.0, 1.0, 2.0, 2.5, 3.0]
    assert plan.motion.keyframes[3].targets_deg == plan.motion.keyframes[1].targets_deg


def test_the_keys_move_the_playhead_play_and_add_as_the_readme_says(timeline):
    studio = timeline.studio
    plan = studio.session.plan
    assert plan is not None
    timeline.press("End")
    wait_for(lambda: studio.time_s == pytest.approx(plan.end_s, abs=1e-3), "End")
    timeline.press("Home")
    wait_for(lambda: studio.time_s == pytest.approx(plan.start_s, abs=1e-3), "Home")
    studio.scrub(1.0)
    wait_for(lambda: timeline.js("tl.time") == 1.0, "the playhead at 1 s")
    timeline.press("ArrowRight")
    wait_for(lambda: studio.time_s == pytest.approx(1.0 + FRAME_S, abs=1e-3), "one frame on")
    timeline.press("ArrowLeft")
    timeline.press("ArrowLeft")
    wait_for(lambda: studio.time_s == pytest.approx(1.0 - FRAME_S, abs=1e-3), "two frames back")
    timeline.press("Shift+ArrowRight")  # the next beat: beat 3
    wait_for(lambda: studio.time_s == pytest.approx(2 * BEAT_S, abs=1e-3), "one beat on")
    timeline.press("Shift+ArrowLeft")
    wait_for(lambda: studio.time_s == pytest.approx(BEAT_S, abs=1e-3), "one beat back")

    timeline.press(" ")
    wait_for(lambda: studio.playing and timeline.js("tl.playing"), "playing")
    song_playing = "!document.getElementById('song').paused"
    wait_for(lambda: timeline.js(song_playing), "the song playing")
    timeline.press(" ")  # Stop pauses both
    wait_for(lambda: not studio.playing and not timeline.js("tl.playing"), "paused")
    wait_for(lambda: not timeline.js(song_playing), "the song paused")
    song_at = timeline.js("document.getElementById('song').currentTime")
    assert song_at == pytest.approx(0.5 + timeline.js("tl.time"), abs=0.05)

    studio.scrub(2.5)
    wait_for(lambda: timeline.js("tl.time") == 2.5, "the playhead at 2.5 s")
    version = studio.session.version
    timeline.press("k")
    wait_for(lambda: studio.session.version > version, "K to add a keyframe")
    assert [round(t, 3) for t in times_in_file(studio)] == [0.0, 1.0, 2.0, 2.5, 3.0]
    added = studio.session.motion_path.read_bytes()
    timeline.press("Control+z")  # the file as it was, byte for byte
    wait_for(lambda: studio.session.motion_path.read_bytes() == WAVE.read_bytes(), "undo")
    timeline.press("Control+Shift+z")
    wait_for(lambda: studio.session.motion_path.read_bytes() == added, "redo")


def test_a_finding_is_a_mark_whose_click_moves_the_playhead_and_names_its_keyframe(timeline):
    studio = timeline.studio
    version = write_motion(studio, STRAINED)
    wait_for(
        lambda: timeline.shows(version) and timeline.js("tl.state.findings.length") > 0, "findings"
    )
    findings = studio.session.plan.findings
    first = min(findings, key=lambda f: f.time_s)
    row = timeline.js("tl.findingY()")
    assert timeline.pixel(first.time_s, row - 4) != (255, 255, 255)
    timeline.click(first.time_s, row)
    wait_for(lambda: studio.time_s == pytest.approx(first.time_s, abs=0.02), "the playhead at it")
    where = f"{studio.session.motion_path}:4"
    wait_for(lambda: any(where in line for line in studio.said), "the finding named")
    status = timeline.frame.locator("#status")
    wait_for(lambda: where in status.inner_text(), "the status line to name it")


def test_every_keyframe_is_drawn_past_sixty_marks(timeline):
    studio = timeline.studio
    version = write_motion(studio, many_keyframes(100, 0.15, swing_deg=1))  # 15 s
    wait_for(lambda: timeline.shows(version), "100 keyframes")
    timeline.press("0")  # fit: all of it in view
    times = timeline.js("tl.state.keyframes.map(k => k.t)")
    assert len(times) == 100
    timeline.js("tl.redraw()")
    missing = undrawn_keyframes(timeline)
    assert missing == []


def test_a_thousand_keyframes_are_all_drawn(timeline):
    studio = timeline.studio
    # 20 s: the base cannot swing in 20 ms, and the studio simulates all of it
    version = write_motion(studio, many_keyframes(1000, 0.02, swing_deg=0))
    wait_for(lambda: timeline.shows(version), "1,000 keyframes")
    timeline.press("0")
    times = timeline.js("tl.state.keyframes.map(k => k.t)")
    assert len(times) == 1000
    timeline.js("tl.redraw()")
    missing = undrawn_keyframes(timeline)
    assert missing == []
