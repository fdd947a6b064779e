"""choreo studio driven in a real browser: Chromium through Playwright.

The run finds or installs the browser first (tests/browser.py: Playwright's own, or Debian's
chromium). Without one these tests fail (they do not skip): the studio is a page, and only a
browser shows that the page works. One studio and one page serve the whole module (a
page's first frames cost seconds of software rendering); each test starts from the motion file
as tests/data/studio/wave.yaml has it. The last test closes the page, as a user closes the last
tab.

Posing with the mouse is tested here too, in the same page (a module of its own cost a second
browser, studio and page load: ~6 s of CPU, Chromium's included): a click on a link shows its
joint's ring, dragging the ring turns the joint that way (within its limits; dragged past one, it
stops there with a line and the ring goes back on the joint), Add writes that joint alone; a
refused drag of a walker's body handle puts the handle back on the body. The mouse goes where the
page draws the ring or the handle: the point of the world (the handle's pose the studio set, the
gizmo's shape as viser draws it) through the camera the tab reported (``on_screen``), not pixels
found by hand. The walker's test saves its motion over the arm's.
"""

from __future__ import annotations

import io
import shutil
import time
from pathlib import Path
from urllib.parse import urlsplit

import browser as chromium
import mujoco
import numpy as np
import pytest
from paths import DATA
from PIL import Image
from playwright.sync_api import expect, sync_playwright
from studio_browser_helpers import (
    ARM_WAVE,
    VIEWPORT,
    WAIT_MS,
    back_to_the_shipped_wave,
    click,
    free_port,
    launched_browser,
    number_input,
    on_screen,
    type_number,
    value_of,
    wait_for,
    without_the_floor,
)
from studio_helpers import body_sway_rise

from choreo.core.atomic import write_text_atomically
from choreo.studio.address import Address
from choreo.studio.journal import Journal
from choreo.studio.scene import BODY, HANDLE_SCALE, JOINT, rotation_of
from choreo.studio.server import Studio

MOTION = DATA / "studio" / "wave.yaml"
SCENE = {"x": 80, "y": 150, "width": 460, "height": 420}  # the 3D view, clear of the panels
DARK = 300  # R+G+B of arm6's black links (the floor, hidden here, draws lighter than 400)
TICK_TOLERANCE_DEG = 0.5  # the ticks may be this far from the plan (choreo play's default)


@pytest.fixture(scope="module")
def browser():
    yield from launched_browser()


@pytest.fixture(scope="module")
def window(browser):
    """One browser window (context) for the module's tabs, as a user opens a second tab: one
    that loads the page again finds viser's script compiled (~2 s of CPU less)."""
    context = browser.new_context(viewport=VIEWPORT)
    yield context
    context.close()


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """The studio on a copy of wave.yaml; ``studio.said`` is what it printed."""
    motion = tmp_path_factory.mktemp("studio") / "wave.yaml"
    shutil.copy(MOTION, motion)
    shutil.copy(MOTION.with_name("groove.ogg"), motion.with_name("groove.ogg"))
    said: list[str] = []
    studio = Studio(motion, Address("127.0.0.1", free_port()), say=said.append)
    studio.said = said  # type: ignore[attr-defined]
    studio.start()
    without_the_floor(studio)
    yield studio
    studio.close()


class Tab:
    """The module's one page, kept open from test to test; opened again if a test closed it."""

    def __init__(self, window, studio):
        self.window, self.studio, self.page = window, studio, None

    def open(self):
        if self.page is None or self.page.is_closed():
            self.page = open_page(self.window, self.studio)
            # "software WebGL": closed, as a user closes it, clear of the gizmos it may cover
            self.page.locator(".mantine-Notification-root button").click()
        return self.page


@pytest.fixture(scope="module")
def tab(window, served):
    one = Tab(window, served)
    yield one
    if one.page is not None:
        one.page.close()


@pytest.fixture
def first_tab(tab):
    return tab.open()


@pytest.fixture
def studio(served, first_tab):
    """The studio with the file as wave.yaml has it, the page showing it at t = 0."""
    if served.session.motion_path.read_bytes() != MOTION.read_bytes():
        version = served.session.version
        shutil.copy(MOTION, served.session.motion_path)
        wait_for(lambda: served.session.version > version, "the studio to reload")
        expect(first_tab.get_by_text("4 keyframes", exact=False)).to_be_visible(timeout=WAIT_MS)
    type_number(first_tab, "t (s)", 0.0)
    expect(number_input(first_tab, "t (s)")).to_have_value("0", timeout=WAIT_MS)
    served.said.clear()
    return served


def open_page(window, studio):
    page = window.new_page()
    page.asked = []  # every URL the page and its frames ask for, the websocket's included
    page.on("request", lambda request: page.asked.append(request.url))
    page.on("websocket", lambda websocket: page.asked.append(websocket.url))
    page.goto(studio.address.url)
    # a new page's first frames take a busy machine's software rendering a minute
    expect(page.get_by_text("studio wave")).to_be_visible(timeout=4 * WAIT_MS)
    return page


def timeline_frame(page, studio):
    """The timeline's page, framed into viser's."""
    element = page.wait_for_selector("#choreo-timeline", timeout=WAIT_MS)
    frame = element.content_frame() if element is not None else None
    assert frame is not None and frame.url == f"{studio.address.url}timeline/"  # the one address
    frame.wait_for_function("() => window.choreoTimeline !== undefined", timeout=WAIT_MS)
    return frame


def scene_pixels(page) -> np.ndarray:
    shot = page.screenshot(clip=SCENE, timeout=WAIT_MS)
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB")).astype(int)


def changed_pixels(a: np.ndarray, b: np.ndarray) -> int:
    return int(np.abs(a - b).sum(axis=2).astype(bool).sum())


def test_the_page_names_and_draws_the_robot_and_scrubbing_moves_it(first_tab, studio):
    page = first_tab
    for name in ("arm6", "base_yaw", "shoulder", "elbow", "wrist_pitch", "wrist_roll", "gripper"):
        expect(page.get_by_text(name, exact=True).first).to_be_attached()
    at_rest = scene_pixels(page)
    robot = int((at_rest.sum(axis=2) < DARK).sum())
    assert robot > 400, f"only {robot} dark pixels: no robot drawn"

    type_number(page, "t (s)", 2.0)  # the third keyframe: base_yaw 30, shoulder 30, elbow 40
    wait_for(lambda: abs(value_of(page, "base_yaw") - 30) <= TICK_TOLERANCE_DEG, "base_yaw 30")
    for joint, angle in (("shoulder", 30), ("elbow", 40), ("gripper", 0)):
        assert value_of(page, joint) == pytest.approx(angle, abs=TICK_TOLERANCE_DEG)
    wait_for(lambda: changed_pixels(scene_pixels(page), at_rest) > 400, "the robot to move")
    # the song, in the page, stands at the timeline's time plus its start (music: start: 0.5)
    song_time = "() => document.getElementById('song').currentTime"
    timeline = timeline_frame(page, studio)
    wait_for(lambda: timeline.evaluate(song_time) == pytest.approx(2.5), "the song at 2.5 s")
    # the page, its websocket, the timeline, its events, requests and song: all on one address
    ours = f"127.0.0.1:{studio.address.port}"
    asked = [urlsplit(url) for url in page.asked]
    assert [url for url in asked if url.scheme not in ("data", "blob") and url.netloc != ours] == []
    assert {(url.scheme, url.path or "/") for url in asked} >= {
        ("http", "/"),
        ("ws", "/"),
        ("http", "/timeline/"),
        ("http", "/timeline/events"),
        ("http", "/timeline/song"),
    }


# The slider's pose written as a keyframe after the one at t 2.0, before the next one's comment:
# these two lines and nothing else: the joints that differ from the keyframe before it, timed as
# its neighbours are (t:).
ADDED = """\
  - pose: {base_yaw: 0, shoulder: 45, elbow: 0}
    t: 2.5
"""


def test_a_slider_and_add_keyframe_write_one_keyframe_and_keep_the_rest(first_tab, studio):
    page = first_tab
    type_number(page, "t (s)", 2.5)
    page.get_by_role("button", name="Take the named pose").click()  # home, the first pose
    expect(number_input(page, "base_yaw")).to_have_value("0", timeout=WAIT_MS)
    type_number(page, "shoulder", 45)
    wait_for(lambda: studio.posing is not None and studio.posing[1] == 45, "the slider's pose")
    page.get_by_role("button", name="Add keyframe").click()
    wait_for(lambda: "5 keyframes" in page.inner_text("body"), "the page to show 5 keyframes")
    lines = MOTION.read_text().splitlines(keepends=True)
    at = lines.index("  # and back\n")
    assert studio.session.motion_path.read_text() == "".join(lines[:at]) + ADDED + "".join(
        lines[at:]
    )
    assert any("added a keyframe" in line for line in studio.said)


def test_a_bad_save_shows_where_in_the_page_and_a_good_save_clears_it(first_tab, studio):
    page = first_tab
    path = studio.session.motion_path
    path.write_text(
        MOTION.read_text().replace("{shoulder: 30, elbow: 40}", "{shoulder: 30, elbw: 40}")
    )
    where = f"{path}:8:"
    expect(page.get_by_text(where)).to_be_visible(timeout=WAIT_MS)
    assert any(line.startswith(where) and "elbw" in line for line in studio.said)
    assert studio.session.plan is not None  # the last good plan is still shown
    expect(page.get_by_text("4 keyframes", exact=False)).to_be_visible()

    shutil.copy(MOTION, path)
    expect(page.get_by_text(where)).to_have_count(0, timeout=WAIT_MS)


def test_a_second_tab_sees_and_changes_the_same_state(window, first_tab, studio):
    second = open_page(window, studio)
    try:
        type_number(second, "t (s)", 1.0)  # the second keyframe: shoulder 30, elbow 40
        expect(number_input(first_tab, "t (s)")).to_have_value("1", timeout=WAIT_MS)
        wait_for(lambda: abs(value_of(first_tab, "elbow") - 40) <= TICK_TOLERANCE_DEG, "elbow")
        # a page asking for an angle outside the joint's limits is refused, in both places
        type_number(second, "gripper", 90)
        expect(first_tab.get_by_text("outside its limits")).to_be_visible(timeout=WAIT_MS)
        assert any("refused: gripper 90° is outside its limits" in s for s in studio.said)
    finally:
        second.close()


def test_keys_pressed_in_the_3d_view_reach_the_timeline(first_tab, studio):
    page = first_tab
    page.mouse.click(300, 200)  # the 3D view
    page.keyboard.press("End")
    plan = studio.session.plan
    assert plan is not None
    wait_for(lambda: studio.time_s == pytest.approx(plan.end_s, abs=1e-3), "End")
    timeline = timeline_frame(page, studio)
    wait_for(lambda: timeline.evaluate("() => window.choreoTimeline.time") == plan.end_s, "End")
    assert page.title() == "choreo studio"


def test_a_click_on_a_link_picks_its_joint_and_frame_the_robot_brings_it_back(first_tab, studio):
    page = first_tab
    (client,) = studio.server.get_clients().values()  # this module's one tab
    view = studio.view
    assert view is not None
    elbow = view.model.joint(view.robot.joint("elbow").mjcf_joint)
    link = view.model.body(int(elbow.bodyid[0]))  # the link the elbow turns
    data = mujoco.MjData(view.model)
    data.qpos[:] = view.qpos
    mujoco.mj_kinematics(view.model, data)
    page.mouse.click(*on_screen(page, client.camera, data.xipos[link.id]))
    expect(page.get_by_text("turning elbow").first).to_be_visible(timeout=WAIT_MS)
    assert studio.view.handle_pose("/joint") is not None

    framed = np.array(studio.server.initial_camera.position)
    client.camera.position = framed * 3  # the user wandered off
    wait_for(lambda: np.allclose(client.camera.position, framed * 3, atol=1e-3), "the camera away")
    click(page, "Frame the robot")
    wait_for(lambda: np.allclose(client.camera.position, framed, atol=1e-3), "the robot framed")


# --- edits an animator can trust: motions/arm6/wave.yaml, timed with after: ----------------------


@pytest.fixture
def arm(served, first_tab):
    """The module's studio and tab on motions/arm6/wave.yaml instead (saved over its file:
    one page for all, as a second page costs a software-rendering browser seconds), nothing
    to undo, at t = 0."""
    back_to_the_shipped_wave(served, first_tab)
    served.journal = Journal(served.session.motion_path)
    type_number(first_tab, "t (s)", 0.0)
    expect(number_input(first_tab, "t (s)")).to_have_value("0", timeout=WAIT_MS)
    served.said.clear()
    return served


def choose(page, label: str, option: str) -> None:
    """Pick ``option`` of the dropdown labelled ``label``."""
    row = f"xpath=//p[normalize-space(.)='{label}']/ancestor::div[contains(@class,'Flex-root')][1]"
    page.locator(row).get_by_role("combobox").click()
    page.get_by_role("option", name=option, exact=True).click()


def test_an_edit_waits_while_the_page_shows_a_plan_older_than_the_file(first_tab, arm):
    page, path = first_tab, arm.session.motion_path
    broken = ARM_WAVE.read_text().replace(
        "  # each flap", "  - pose: {elbow: -10}\n    t: 1.2\n  # each flap", 1
    )
    path.write_text(broken)  # saved in an editor: loads, but the elbow cannot be there in time
    expect(page.get_by_text("cannot be reached at 1.200 s").first).to_be_visible(timeout=WAIT_MS)
    choose(page, "keyframe", "4 · t 1.80 s · wave.yaml:14")  # of the plan still shown
    click(page, "Update keyframe")
    expect(page.get_by_text("the page shows the last plan that worked")).to_be_visible(
        timeout=WAIT_MS
    )
    click(page, "Delete keyframe")

    def refusals() -> list[str]:
        return [line for line in arm.said if line.startswith("⛔")]

    wait_for(lambda: len(refusals()) == 2, "the second refusal")
    assert all(line.startswith("⛔ nothing written: the page shows") for line in refusals())
    assert path.read_text() == broken


def test_a_move_that_would_not_plan_is_refused_with_the_time_that_works(first_tab, arm):
    page, path = first_tab, arm.session.motion_path
    choose(page, "keyframe", "5 · t 2.20 s · wave.yaml:16")
    expect(number_input(page, "t (s)")).to_have_value("2.2", timeout=WAIT_MS)
    type_number(page, "t (s)", 2.1)
    wait_for(lambda: arm.time_s == 2.1, "the timeline at 2.1 s")
    click(page, "Move keyframe here")
    expect(page.get_by_text("the nearest time that works is 2.20 s")).to_be_visible(timeout=WAIT_MS)
    assert path.read_bytes() == ARM_WAVE.read_bytes()


def test_an_added_keyframe_keeps_the_others_in_time_and_undo_redo_restore_the_bytes(first_tab, arm):
    page, path = first_tab, arm.session.motion_path
    original = path.read_bytes()
    type_number(page, "t (s)", 4.4)  # between 3.4 s (held 0.3 s) and 4.9 s (after: 1.2)
    wait_for(lambda: arm.time_s == 4.4, "the timeline at 4.4 s")  # the page's calls may cross
    click(page, "Take the named pose")  # home: the joints that differ from keyframe 8 are written
    wait_for(lambda: arm.posing is not None and not arm.posing.any(), "home")
    click(page, "Add keyframe")
    expect(page.get_by_text("10 keyframes · 5.40 s", exact=False)).to_be_visible(timeout=WAIT_MS)
    added = path.read_bytes()
    assert added == original.replace(
        b"    hold: 0.3\n  - pose: home\n    after: 1.2\n",
        b"    hold: 0.3\n  - pose: {shoulder: 0, elbow: 0, wrist_pitch: 0, gripper: 0}\n"
        b"    after: 0.7\n  - pose: home\n    after: 0.5\n",
    )
    click(page, "Undo")
    expect(page.get_by_text("9 keyframes · 5.40 s", exact=False)).to_be_visible(timeout=WAIT_MS)
    assert path.read_bytes() == original
    click(page, "Redo")
    expect(page.get_by_text("10 keyframes · 5.40 s", exact=False)).to_be_visible(timeout=WAIT_MS)
    assert path.read_bytes() == added


def test_update_writes_only_the_joint_moved_and_add_on_a_keyframe_offers_update(first_tab, arm):
    page, path = first_tab, arm.session.motion_path
    choose(page, "keyframe", "3 · t 1.40 s · wave.yaml:12")
    expect(number_input(page, "t (s)")).to_have_value("1.4", timeout=WAIT_MS)
    type_number(page, "elbow", -24)
    wait_for(lambda: arm.posing is not None and arm.posing[2] == -24, "the slider's pose")
    click(page, "Add keyframe")  # a keyframe stands here: it is the one to update
    expect(page.get_by_text("Update writes the pose into it")).to_be_visible(timeout=WAIT_MS)
    assert path.read_bytes() == ARM_WAVE.read_bytes()
    click(page, "Update keyframe")
    wait_for(lambda: path.read_bytes() != ARM_WAVE.read_bytes(), "the update")
    assert path.read_text() == ARM_WAVE.read_text().replace(
        "{elbow: -22, wrist_pitch: 20}", "{elbow: -24, wrist_pitch: 20}", 1
    )


# --- posing with the mouse: a joint's ring, a walker's body handle (motions/arm6/wave.yaml) ---

AFTER_THE_LAST_S = 5.2  # wave's last keyframe (home) is at 4.9 s: the arm stands at home
# viser's gizmo (drei's PivotControls) draws the ring about its x axis as a quarter circle from
# its y axis to its z axis, 0.65 of its scale out, and its x arrow along x; both #ff2060
RING_SHARE, RED = 0.65, (0xFF, 0x20, 0x60)
COLOUR_TOLERANCE = 60  # antialiased lines blend with what is behind them
NEAR_PX = 3  # a point of the gizmo is drawn if a pixel of its colour is this close
# links in front hide a part of it; a gizmo elsewhere may cross a few of the points
DRAWN, NOT_DRAWN = 0.6, 0.2
DRAG_TOLERANCE_DEG = 1.5  # the mouse lands on whole pixels: a few tenths of a degree off


@pytest.fixture
def at_home(arm, first_tab):
    """The studio on motions/arm6/wave.yaml as shipped (``arm``), the page at 5.2 s: arm6 at
    home, after the last keyframe. Scrubbed from here, not typed: 5.2 typed right after
    ``arm`` typed 0 was now and then lost (2 runs in 6; the posing tests' own fixture typed
    both too)."""
    arm.scrub(AFTER_THE_LAST_S)
    expect(number_input(first_tab, "t (s)")).to_have_value("5.2", timeout=WAIT_MS)
    assert arm.time_s == AFTER_THE_LAST_S
    arm.said.clear()
    return arm


def red_pixels(page, corner: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
    """Where the page draws the gizmo's red in the region of ``size`` (width, height) page
    pixels at ``corner`` (x, y): rows, columns from the corner. A clip, not the whole page:
    polled while software rendering catches up, a full page costs Chromium ~0.2 s a shot."""
    clip = {"x": corner[0], "y": corner[1], "width": size[0], "height": size[1]}
    shot = Image.open(io.BytesIO(page.screenshot(clip=clip))).convert("RGB")
    return np.abs(np.asarray(shot).astype(int) - np.array(RED)).max(axis=2) <= COLOUR_TOLERANCE


def share_drawn(red: np.ndarray, corner: tuple[int, int], pixels) -> float:
    """The share of ``pixels`` (x, y on the page) drawn in the gizmo's red where ``red``
    (the region at ``corner``) is set."""
    drawn = 0
    for x, y in pixels:
        row, column = y - corner[1], x - corner[0]
        near = red[row - NEAR_PX : row + NEAR_PX + 1, column - NEAR_PX : column + NEAR_PX + 1]
        drawn += bool(near.any())
    return drawn / len(pixels)


def draws_gizmo(page, camera, on_m, off_m=()) -> bool:
    """Whether the page draws a gizmo (its red ring or arrow) along ``on_m`` and not along
    ``off_m`` (points of the world, m)."""
    on, off = ([on_screen_px(page, camera, p) for p in points] for points in (on_m, off_m))
    xs, ys = [x for x, _ in on + off], [y for _, y in on + off]
    corner = (max(0, min(xs) - NEAR_PX), max(0, min(ys) - NEAR_PX))
    size = (max(xs) + NEAR_PX + 1 - corner[0], max(ys) + NEAR_PX + 1 - corner[1])
    page.mouse.move(1, 1)  # a gizmo under the mouse is drawn highlighted, not red
    red = red_pixels(page, corner, size)
    shown = share_drawn(red, corner, on) >= DRAWN
    return shown and (not off or share_drawn(red, corner, off) <= NOT_DRAWN)


def on_screen_px(page, camera, point_m) -> tuple[int, int]:
    """The page pixel (x, y) where the 3D view draws ``point_m`` (world, m)."""
    x, y = on_screen(page, camera, point_m)
    return int(round(x)), int(round(y))


def wait_until_drawn(page, camera, on_m, off_m=(), what: str = "the gizmo") -> None:
    """Until the page draws the gizmo along ``on_m`` and not ``off_m``: software rendering
    takes a while to show a change."""
    wait_for(lambda: draws_gizmo(page, camera, on_m, off_m), f"{what} drawn there")


def handle_size(studio) -> float:
    assert studio.view is not None
    return float(studio.view.model.stat.extent) * HANDLE_SCALE


def ring_points(studio, degrees) -> list[np.ndarray]:
    """Points of the joint's ring (world, m) as the studio last placed it, ``degrees`` round
    from the ring's start (its y axis) towards its end (its z axis): turning the ring from one
    to the next turns it about its x axis, the joint's axis, by the difference."""
    position, wxyz = studio.view.handle_pose(JOINT)
    rotation, radius = rotation_of(wxyz), RING_SHARE * handle_size(studio)
    return [
        position + radius * (np.cos(a) * rotation[:, 1] + np.sin(a) * rotation[:, 2])
        for a in np.radians(degrees)
    ]


def pick(page, studio, joint: str) -> None:
    """Click the link ``joint`` turns, where the page draws it; its ring shows."""
    (client,) = studio.server.get_clients().values()
    view = studio.view
    link = int(view.model.joint(view.robot.joint(joint).mjcf_joint).bodyid[0])
    data = mujoco.MjData(view.model)
    data.qpos[:] = view.qpos
    mujoco.mj_kinematics(view.model, data)
    page.mouse.click(*on_screen(page, client.camera, data.xipos[link]))
    expect(page.get_by_text(f"turning {joint}").first).to_be_visible(timeout=WAIT_MS)


def press(page, camera, point_m) -> None:
    """The mouse down where the page draws ``point_m`` (world, m)."""
    page.mouse.move(*on_screen(page, camera, point_m))
    page.mouse.down()


def move(page, camera, point_m) -> None:
    page.mouse.move(*on_screen(page, camera, point_m), steps=3)


def joint_values(page, names) -> dict[str, float]:
    return {name: value_of(page, name) for name in names}


def shows_elbow(page, studio, angle_deg: float) -> bool:
    """The page shows the elbow at ``angle_deg``, as the studio posed it."""
    shown = value_of(page, "elbow")
    posed = studio.posing
    elbow = studio.view.robot.joint_names.index("elbow")
    return (
        abs(shown - angle_deg) <= DRAG_TOLERANCE_DEG and posed is not None and shown == posed[elbow]
    )


def test_dragging_a_joints_ring_turns_it_that_way_and_add_writes_that_joint_alone(
    first_tab, at_home
):
    page, arm = first_tab, at_home
    path = arm.session.motion_path
    (client,) = arm.server.get_clients().values()
    names = arm.view.robot.joint_names
    before = joint_values(page, names)
    pick(page, arm, "elbow")
    wait_until_drawn(page, client.camera, ring_points(arm, range(5, 90, 5)), what="the ring")

    # 20° back along the ring, from its middle: the elbow turns -20° about its axis
    points = ring_points(arm, [65, 60, 55, 50, 45])
    press(page, client.camera, points[0])
    for point in points[1:]:
        move(page, client.camera, point)
    page.mouse.up()
    wait_for(lambda: shows_elbow(page, arm, before["elbow"] - 20), "the elbow turned -20°")
    shown = joint_values(page, names)
    assert {n: a for n, a in shown.items() if n != "elbow"} == {
        n: a for n, a in before.items() if n != "elbow"
    }
    # the ring went with the joint: drawn where the studio put it
    wait_until_drawn(page, client.camera, ring_points(arm, range(5, 90, 5)), what="the ring")

    click(page, "Add keyframe")
    wait_for(lambda: path.read_bytes() != ARM_WAVE.read_bytes(), "the keyframe written")
    assert path.read_text() == ARM_WAVE.read_text() + (
        f"  - pose: {{elbow: {shown['elbow']:g}}}\n    after: 0.3\n"
    )
    expect(page.get_by_text("10 keyframes", exact=False)).to_be_visible(timeout=WAIT_MS)


def test_a_ring_dragged_past_the_joints_limit_stops_there_and_goes_back_on_the_joint(
    first_tab, at_home
):
    page, arm = first_tab, at_home
    (client,) = arm.server.get_clients().values()
    elbow, limits = arm.view.robot.joint_names.index("elbow"), arm.view.robot.joint("elbow").limits
    pick(page, arm, "elbow")
    start = value_of(page, "elbow")
    within = limits.max_deg - 10 - start  # up to 10° short of the limit: taken
    beyond = limits.max_deg + 30 - start  # then 30° past it: the elbow stops at the limit
    points = ring_points(arm, [45, 45 + within / 2, 45 + within, 45 + beyond])
    press(page, client.camera, points[0])
    for point, angle in zip(points[1:3], (start + within / 2, start + within)):
        move(page, client.camera, point)
        wait_for(lambda angle=angle: shows_elbow(page, arm, angle), f"the elbow at {angle:g}°")
    move(page, client.camera, points[3])
    wait_for(lambda: any("stops at its limit" in line for line in arm.said), "the line")
    page.mouse.up()

    stop = f"elbow stops at its limit {limits.max_deg:g}°"
    expect(page.get_by_text(stop).first).to_be_visible(timeout=WAIT_MS)
    assert [line for line in arm.said if "stops at its limit" in line][0].startswith(stop)
    wait_for(lambda: shows_elbow(page, arm, limits.max_deg), "the elbow at its limit")
    assert arm.posing[elbow] == limits.max_deg

    # the ring is drawn back on the joint, at its limit, not 30° on where the mouse left it:
    # once the studio has heard the mouse let go (a message after the last move's; on a busy
    # machine it came after the elbow was shown at its limit, 1 run in 5)
    def ring_at_the_limit() -> bool:
        _, wxyz = arm.view.handle_pose(JOINT)
        return arm.view.turned_deg(elbow, wxyz) == pytest.approx(limits.max_deg, abs=0.05)

    wait_for(ring_at_the_limit, "the ring put back at the limit")
    back, floated = ring_points(arm, range(5, 30, 5)), ring_points(arm, range(95, 120, 5))
    wait_until_drawn(page, client.camera, back, floated, "the ring back on the elbow")


@pytest.fixture
def walker(served, first_tab):
    """The module's studio and page on hexapod18 (saved over its file: the studio shows the
    robot a save names), framed, at t = 0."""
    served.scrub(0.0)  # the plan's pose, not the arm's sliders'
    version = served.session.version
    # body_sway's rise: a walker (the studio simulates all of a motion it loads)
    write_text_atomically(served.session.motion_path, body_sway_rise())
    # the robot drawn as simulated, as a studio started on the file draws it
    session = served.session
    wait_for(
        lambda: session.version > version and session.plan and session.plan.physics, "the physics"
    )
    plan = session.plan
    assert plan.motion.robot.name == "hexapod18" and session.problems == ()
    keyframes = f"{len(plan.motion.keyframes)} keyframes"
    expect(first_tab.get_by_text(keyframes, exact=False)).to_be_visible(timeout=WAIT_MS)
    without_the_floor(served)  # the hexapod's scene has a floor of its own
    served.frame_robot()
    served.said.clear()
    return served


def x_arrow(studio, origin_m: np.ndarray, rotation: np.ndarray) -> list[np.ndarray]:
    """Points along the red arrow of a gizmo at ``origin_m`` turned by ``rotation``, clear of
    its rings (they cross its axes at 0.65 of its size)."""
    size = handle_size(studio)
    return [origin_m + share * size * rotation[:, 0] for share in (0.3, 0.4, 0.5, 0.8, 0.9)]


def test_a_body_drag_out_of_the_legs_reach_is_refused_and_the_handle_goes_back(first_tab, walker):
    page = first_tab
    (client,) = walker.server.get_clients().values()
    position, wxyz = walker.view.handle_pose(BODY)
    rotation = rotation_of(wxyz)
    wait_until_drawn(page, client.camera, x_arrow(walker, position, rotation))

    up, lift_m = rotation[:, 2], 0.25  # the body 25 cm up: no leg reaches the floor
    grab = position + 0.85 * handle_size(walker) * up  # on the blue arrow, near its tip
    press(page, client.camera, grab)
    move(page, client.camera, grab + lift_m * up)
    wait_for(lambda: any(line.startswith("⛔") for line in walker.said), "the refusal")
    page.mouse.up()

    expect(page.get_by_text("the body cannot go there").first).to_be_visible(timeout=WAIT_MS)
    assert all(
        line.startswith("⛔ refused: the body cannot go there: foot ")
        for line in walker.said
        if line.startswith("⛔")
    )
    # the handle is back on the body as the page draws it, not where the mouse left it
    root, _ = walker.view.root_pose()
    floated = x_arrow(walker, root + lift_m * up, rotation)
    back = x_arrow(walker, root, rotation)
    wait_until_drawn(page, client.camera, back, floated, "the handle back on the body")
    assert np.allclose(walker.view.handle_pose(BODY)[0], root)


def test_playback_stops_when_the_last_tab_closes(first_tab, studio):
    wait_for(lambda: len(studio.server.get_clients()) == 1, "the module's one tab")
    studio.toggle_play()  # as its Play button does
    wait_for(lambda: studio.playing and studio.time_s > 0.2, "the timeline to play")
    first_tab.close()  # the last tab (a later test opens the module's page again)
    wait_for(lambda: not studio.playing, "playback to stop")
    stopped_at = studio.time_s
    time.sleep(0.2)  # the player's frames: the timeline stays
    assert studio.time_s == stopped_at


def screenshot(motion: Path, at_s: float, out: Path) -> None:
    """The README's picture of the studio, from the repo's root:
    ``PYTHONPATH=tests python tests/studio/test_studio_browser.py docs/studio.png``."""
    choice = chromium.chosen()  # before Playwright starts: finding it may start one
    studio = Studio(motion, Address("127.0.0.1", free_port()), say=print)
    studio.start()
    try:
        with sync_playwright() as playwright:
            browser = choice.launch(playwright)
            page = browser.new_page(viewport={"width": 1280, "height": 820})
            page.goto(studio.address.url)
            expect(page.get_by_text("Timeline")).to_be_visible(timeout=WAIT_MS)
            page.locator(".mantine-Notification-root button").click()  # "software WebGL" note
            timeline = timeline_frame(page, studio)
            timeline.wait_for_function("() => window.choreoTimeline.state !== null")
            for joint in ("shoulder", "elbow"):  # their curves too
                studio_label = timeline.locator("#canvas")
                y = timeline.evaluate(
                    f"() => {{ const L = window.choreoTimeline.layout(); const r = L.rows"
                    f".findIndex(r => r.kind === 'joint' && window.choreoTimeline.state"
                    f".joints[r.j].name === '{joint}'); return L.lanesTop + r * 16 + 8; }}"
                )
                studio_label.click(position={"x": 60, "y": y})
            type_number(page, "t (s)", at_s)
            page.mouse.move(600, 300)  # no tooltip in the picture
            page.screenshot(path=out, timeout=WAIT_MS)  # the first frames take a while
            time.sleep(1.0)
            page.screenshot(path=out, timeout=WAIT_MS)
            browser.close()
    finally:
        studio.close()


if __name__ == "__main__":
    import sys

    screenshot(Path("motions/arm6/dance.yaml"), 8.4, Path(sys.argv[1]))
