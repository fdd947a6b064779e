"""Posing in choreo studio with the mouse, in Chromium: a click on a link shows its joint's ring,
dragging the ring turns the joint that way (within its limits; dragged past one, it stops there
with a line and the ring goes back on the joint), Add writes that joint alone; a refused drag of
a walker's body handle puts the handle back on the body.

The mouse goes where the page draws the ring or the handle: the point of the world (the handle's
pose the studio set, the gizmo's shape as viser draws it) through the camera the tab reported
(``on_screen``), not pixels found by hand. One studio and one page serve the module (a page's
first frames cost seconds of software rendering): the walker's test saves its motion over the
arm's.
"""

from __future__ import annotations

import io
import shutil

import mujoco
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect
from studio_browser_helpers import (
    ARM_WAVE,
    VIEWPORT,
    WAIT_MS,
    back_to_the_shipped_wave,
    click,
    free_port,
    launched_browser,
    on_screen,
    type_number,
    value_of,
    wait_for,
    without_the_floor,
)
from studio_helpers import body_sway_rise

from choreo.core.atomic import write_text_atomically
from choreo.studio.address import Address
from choreo.studio.scene import BODY, HANDLE_SCALE, JOINT, rotation_of
from choreo.studio.server import Studio

AFTER_THE_LAST_S = 5.2  # wave's last keyframe (home) is at 4.9 s: the arm stands at home
# viser's gizmo (drei's PivotControls) draws the ring about its x axis as a quarter circle from
# its y axis to its z axis, 0.65 of its scale out, and its x arrow along x; both #ff2060
RING_SHARE, RED = 0.65, (0xFF, 0x20, 0x60)
COLOUR_TOLERANCE = 60  # antialiased lines blend with what is behind them
NEAR_PX = 3  # a point of the gizmo is drawn if a pixel of its colour is this close
# links in front hide a part of it; a gizmo elsewhere may cross a few of the points
DRAWN, NOT_DRAWN = 0.6, 0.2
DRAG_TOLERANCE_DEG = 1.5  # the mouse lands on whole pixels: a few tenths of a degree off


@pytest.fixture(scope="module")
def browser():
    yield from launched_browser()


@pytest.fixture(scope="module")
def arm_served(tmp_path_factory):
    path = tmp_path_factory.mktemp("posing") / ARM_WAVE.name
    shutil.copy(ARM_WAVE, path)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", free_port()), say=said.append)
    studio.said = said  # type: ignore[attr-defined]
    studio.start()
    without_the_floor(studio)
    yield studio
    studio.close()


@pytest.fixture(scope="module")
def tab(browser, arm_served):
    """The module's one page (a page's first frames cost seconds of software rendering, an open
    page a share of a core): the walker's test shows its robot in it too."""
    page = browser.new_page(viewport=VIEWPORT)
    page.goto(arm_served.address.url)
    # a new page's first frames take a busy machine's software rendering a minute
    expect(page.get_by_text("9 keyframes", exact=False)).to_be_visible(timeout=4 * WAIT_MS)
    page.locator(".mantine-Notification-root button").click()  # "software WebGL"
    yield page
    page.close()


@pytest.fixture
def arm(arm_served, tab):
    """The studio on wave.yaml as shipped, the page at 5.2 s: arm6 at home, after the last
    keyframe."""
    back_to_the_shipped_wave(arm_served, tab)
    type_number(tab, "t (s)", 0.0)  # a change, whatever the time was: the pose is the plan's
    type_number(tab, "t (s)", AFTER_THE_LAST_S)
    wait_for(lambda: arm_served.time_s == AFTER_THE_LAST_S, "the timeline at 5.2 s")
    arm_served.said.clear()
    return arm_served


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


def test_dragging_a_joints_ring_turns_it_that_way_and_add_writes_that_joint_alone(tab, arm):
    page, path = tab, arm.session.motion_path
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


def test_a_ring_dragged_past_the_joints_limit_stops_there_and_goes_back_on_the_joint(tab, arm):
    page = tab
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
    # the ring is drawn back on the joint, at its limit, not 30° on where the mouse left it
    _, wxyz = arm.view.handle_pose(JOINT)
    assert arm.view.turned_deg(elbow, wxyz) == pytest.approx(limits.max_deg, abs=0.05)
    back, floated = ring_points(arm, range(5, 30, 5)), ring_points(arm, range(95, 120, 5))
    wait_until_drawn(page, client.camera, back, floated, "the ring back on the elbow")


@pytest.fixture
def walker(arm_served, tab):
    """The module's studio and page on hexapod18 (saved over its file: the studio shows the
    robot a save names), framed, at t = 0."""
    arm_served.scrub(0.0)  # the plan's pose, not the arm's sliders'
    version = arm_served.session.version
    # body_sway's rise: a walker (the studio simulates all of a motion it loads)
    write_text_atomically(arm_served.session.motion_path, body_sway_rise())
    # the robot drawn as simulated, as a studio started on the file draws it
    session = arm_served.session
    wait_for(
        lambda: session.version > version and session.plan and session.plan.physics, "the physics"
    )
    plan = session.plan
    assert plan.motion.robot.name == "hexapod18" and session.problems == ()
    keyframes = f"{len(plan.motion.keyframes)} keyframes"
    expect(tab.get_by_text(keyframes, exact=False)).to_be_visible(timeout=WAIT_MS)
    without_the_floor(arm_served)  # the hexapod's scene has a floor of its own
    arm_served.frame_robot()
    arm_served.said.clear()
    return arm_served


def x_arrow(studio, origin_m: np.ndarray, rotation: np.ndarray) -> list[np.ndarray]:
    """Points along the red arrow of a gizmo at ``origin_m`` turned by ``rotation``, clear of
    its rings (they cross its axes at 0.65 of its size)."""
    size = handle_size(studio)
    return [origin_m + share * size * rotation[:, 0] for share in (0.3, 0.4, 0.5, 0.8, 0.9)]


def test_a_body_drag_out_of_the_legs_reach_is_refused_and_the_handle_goes_back(tab, walker):
    page = tab
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
