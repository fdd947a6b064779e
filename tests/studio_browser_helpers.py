"""The studio's page in Chromium: the browser, its number boxes and buttons, and where the 3D
view draws a point of the world (to put the mouse on a link or a handle)."""

from __future__ import annotations

import shutil
import socket
import time
from collections.abc import Iterator

import browser as chromium
import mujoco
import numpy as np
import pytest
from paths import REPO
from playwright.sync_api import Browser, expect, sync_playwright

ARM_WAVE = REPO / "motions" / "arm6" / "wave.yaml"

VIEWPORT = {"width": 900, "height": 640}
WAIT_MS = 30_000  # how long a page may take to show a change (software rendering, busy CI box)


def launched_browser() -> Iterator[Browser]:
    """Chromium for a module's tests (a fixture's body: it fails them when there is none)."""
    try:
        choice = chromium.chosen()
    except chromium.NoBrowser as error:
        pytest.fail(str(error), pytrace=False)
    with sync_playwright() as playwright:
        browser = choice.launch(playwright)
        yield browser
        browser.close()


def without_the_floor(studio) -> None:
    """The floor's grid hidden from the studio's pages (these tests' only: users see it).
    Software WebGL spends most of a frame on it (an idle page ~0.3 core, a third of that
    without it), and no test looks at the floor: they look at the robot, the gizmos and the
    panels. Found by the name mjviser gives a plane fixed in the world."""
    view = studio.view
    assert view is not None
    model = view.model
    planes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert planes, "no floor in the scene"
    for geom in planes:
        body = model.body(int(model.geom_bodyid[geom])).name
        handle = studio.server.scene.get_handle_by_name(
            f"/fixed_bodies/{body}/{model.geom(geom).name}"
        )
        assert handle is not None, f"mjviser drew no floor named for {body}"
        handle.visible = False


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def wait_for(condition, what: str, timeout_s: float = WAIT_MS / 1000):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"gave up waiting for {what}"
        time.sleep(0.05)


def back_to_the_shipped_wave(studio, page) -> None:
    """The studio's file as motions/arm6/wave.yaml ships (saved over it, if an earlier test
    changed it), reloaded and shown: one studio and page for a module's tests."""
    path = studio.session.motion_path
    if path.read_bytes() != ARM_WAVE.read_bytes():
        version = studio.session.version
        shutil.copy(ARM_WAVE, path)
        wait_for(lambda: studio.session.version > version, "the studio to reload")
        expect(page.get_by_text("9 keyframes", exact=False)).to_be_visible(timeout=WAIT_MS)


def number_input(page, label: str):
    """The number box beside the control labelled ``label``."""
    row = f"xpath=//p[normalize-space(.)='{label}']/ancestor::div[contains(@class,'Flex-root')][1]"
    return page.locator(row).locator("input").last


def type_number(page, label: str, value: float) -> None:
    box = number_input(page, label)
    box.fill(f"{value:g}")
    box.press("Enter")


def value_of(page, label: str) -> float:
    return float(number_input(page, label).input_value())


def click(page, button: str) -> None:
    page.get_by_role("button", name=button, exact=True).click()


def on_screen(page, camera, point_m: np.ndarray) -> tuple[float, float]:
    """Where the 3D view's canvas draws ``point_m`` (world, m) for a tab's ``camera`` (the
    camera the tab reported to viser: its place, target, up and vertical field of view): page
    pixels."""
    box = page.locator("canvas").first.bounding_box()
    assert box is not None
    position = np.array(camera.position)
    forward = np.array(camera.look_at) - position
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera.up_direction)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = np.asarray(point_m) - position
    depth, half = relative @ forward, np.tan(camera.fov / 2)
    x = relative @ right / (depth * half * box["width"] / box["height"])
    y = relative @ up / (depth * half)
    return box["x"] + (x + 1) / 2 * box["width"], box["y"] + (1 - y) / 2 * box["height"]
