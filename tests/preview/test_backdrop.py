"""choreo.preview.backdrop: the still geoms drawn once, what moves laid over them, the frame the
same as drawn whole. Renders for real (offscreen GL: test_render.py)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from paths import REPO

from choreo.motion.motion_file import load_motion
from choreo.preview import backdrop, gl, simulate_motion
from choreo.preview.model import load_model
from choreo.preview.render import CameraPose, FrameRenderer, frame_camera

# a fixed arm carrying a free prop (the block) over a fixed one: every kind of geom
PICK = REPO / "motions" / "arm6" / "pick_and_place.yaml"
SIZE = (161, 121)  # odd: a row is no whole number of 4-byte words in RGB


@pytest.fixture(scope="module")
def rollout():
    return simulate_motion(load_motion(PICK)).rollout


def frames(rollout, steps, alpha=None) -> tuple[list[np.ndarray], list[bool]]:
    """The frames of ``steps`` from one camera, each drawn whole by a renderer of its own and
    by one renderer for them all (which lays what moves over its backdrop): whether each is
    the same both ways, and the frames drawn whole."""
    model = load_model(rollout.robot, rollout.props)
    if alpha is not None:  # the arm's links made see-through
        moving = model.body_weldid[model.geom_bodyid] != 0
        model.geom_rgba[moving, 3] = alpha
        model.geom_matid[moving] = -1
    camera = frame_camera(model, rollout, SIZE[0] / SIZE[1])
    data = mujoco.MjData(model)
    whole, laid_over = [], []
    with FrameRenderer(model, *SIZE, gl.offscreen_backend()) as renderer:
        for step in steps:
            data.qpos[:] = rollout.qpos[step]
            mujoco.mj_forward(model, data)
            with FrameRenderer(model, *SIZE, gl.offscreen_backend()) as alone:
                whole.append(alone.render(data, camera, ("t", "0"), ("", "")))
            laid_over.append(renderer.render(data, camera, ("t", "0"), ("", "")))
    return [np.array_equal(a, b) for a, b in zip(whole, laid_over)], whole


def test_what_moves_laid_over_the_backdrop_is_the_frame_drawn_whole(rollout, monkeypatch):
    laid = []
    draw_over = backdrop.Backdrop.draw_over
    monkeypatch.setattr(
        backdrop.Backdrop, "draw_over", lambda *a: laid.append(draw_over(*a)) or laid[-1]
    )
    # the arm at rest, reaching for the block, carrying it
    steps = np.linspace(0, len(rollout.times_s) - 1, 4).astype(int)
    same, whole = frames(rollout, steps)
    assert laid == [True] * 3  # the first frame from a camera is drawn whole
    assert same == [True] * 4
    assert not np.array_equal(whole[1], whole[2])  # the frames show the arm moving


def test_a_frame_with_something_see_through_that_moves_is_drawn_whole(rollout, monkeypatch):
    laid = []
    draw_over = backdrop.Backdrop.draw_over
    monkeypatch.setattr(
        backdrop.Backdrop, "draw_over", lambda *a: laid.append(draw_over(*a)) or laid[-1]
    )
    same, _ = frames(rollout, [0, len(rollout.times_s) // 2], alpha=0.5)
    assert laid == [False]  # blended with what is behind it: not laid over
    assert same == [True, True]


TWINS = """
<mujoco>
  <worldbody>
    <light directional="true" dir="0 0 -1"/>
    <geom name="still" type="box" size=".1 .1 .1" pos="0 0 .1" rgba="1 0 0 1"/>
    <body pos="0 0 .1">
      <joint type="slide" axis="1 0 0"/>
      <geom name="moving" type="box" size=".1 .1 .1" rgba="0 0 1 1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_what_moves_wins_a_tie_with_the_backdrop_as_in_mujocos_depth_test():
    """Two boxes in one place, one still and one that moves: MuJoCo draws the still one first
    and the moving one over it where it is as near (GEQUAL), so both ways it is all blue."""
    model = mujoco.MjModel.from_xml_string(TWINS)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = CameraPose((0, 0, 0.1), 1.0, 140, -20)
    with FrameRenderer(model, 64, 48, gl.offscreen_backend()) as renderer:
        whole = renderer.render(data, camera, ("", ""), ("", ""))
        laid_over = renderer.render(data, camera, ("", ""), ("", ""))
    box = whole[..., 2] > 2 * whole[..., 0]  # blue over red
    assert box.sum() > 200
    assert np.array_equal(laid_over, whole)


def test_the_frames_gl_copy_is_freed_with_the_renderer(rollout):
    """The texture and framebuffer a frame laid over is copied through (backdrop.py) go with
    the renderer: the GL context is kept for the thread's next render (gl.py), they would not."""
    from OpenGL import GL

    model = load_model(rollout.robot, rollout.props)
    camera = frame_camera(model, rollout, SIZE[0] / SIZE[1])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with FrameRenderer(model, *SIZE, gl.offscreen_backend()) as renderer:
        for _ in range(2):  # the second laid over the backdrop
            renderer.render(data, camera, ("t", "0"), ("", ""))
        texture, framebuffer = renderer._backdrop._layer
        assert GL.glIsTexture(texture) and GL.glIsFramebuffer(framebuffer)
    renderer._gl.make_current()  # the kept context, given back
    assert not GL.glIsTexture(texture) and not GL.glIsFramebuffer(framebuffer)
