"""The still part of a preview's picture, drawn once for a camera that stays put.

A preview's camera rarely moves (render.frame_cameras: one camera for the whole rollout unless
the robot walks far), and the floor, the sky, fixed props and a fixed robot's base never do, yet
Mesa's software renderer (llvmpipe) fills every one of their pixels on every frame: a quarter of
a 320x240 frame's CPU, more at 640x480. They are drawn once (the backdrop: its colours and its
depths), and each frame draws only what moves, laid over the backdrop where it is as near or
nearer, as MuJoCo's own depth test lays it (``glDepthFunc(GL_GEQUAL)`` on a reversed depth,
render_gl3.c). The picture is the same, pixel for pixel, where nothing that moves is transparent
(blended with what is behind it: such a frame is drawn whole) and nothing casts a shadow or
reflects (the renderer's high quality, which draws every frame whole).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import mujoco
import numpy as np

OPAQUE_ALPHA = 0.995  # MuJoCo blends a geom whose alpha is below this (render_gl3.c)
# MuJoCo's categories: the still geoms (of the world and of bodies welded to it), the rest
STILL = mujoco.mjtCatBit.mjCAT_STATIC
MOVING = mujoco.mjtCatBit.mjCAT_DYNAMIC | mujoco.mjtCatBit.mjCAT_DECOR

# draw(categories, sky): the scene at this frame's state, its geoms of ``categories`` (a mask
# of mjtCatBit), with or without the sky, drawn into the current GL framebuffer; the scene
Draw = Callable[[int, bool], mujoco.MjvScene]


class Backdrop:
    """The still geoms and the sky seen from one camera (``camera``), for frames of
    ``width`` x ``height``."""

    def __init__(self, width: int, height: int):
        self.camera: object = None  # the camera the backdrop was drawn from
        self._size = (height, width)

    @functools.cached_property
    def _buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The backdrop's colours and depths, and a frame's: made when first drawn (a camera
        that follows the robot never is). Colours are read as RGBA (a pixel is laid over as
        one uint32), which GL draws into its RGBA framebuffer without converting: RGB took 4x
        the CPU."""
        colours = [np.empty((*self._size, 4), np.uint8) for _ in range(2)]
        depths = [np.empty(self._size, np.float32) for _ in range(2)]
        return colours[0], depths[0], colours[1], depths[1]

    def draw_over(self, draw: Draw, camera: object) -> bool:
        """Draw the frame into the GL framebuffer as ``draw`` would draw it whole: what moves,
        laid over the backdrop (drawn first if ``camera`` is another). False, with nothing
        drawn that counts, when something that moves is transparent."""
        still_colour, still_depth, colour, depth = self._buffers
        if camera != self.camera:
            draw(STILL, True)
            _read(still_colour, still_depth)
            self.camera = camera
        scene = draw(MOVING, False)
        if any(scene.geoms[i].rgba[3] < OPAQUE_ALPHA for i in range(scene.ngeom)):
            return False
        _read(colour, depth)
        # the backdrop where it is nearer than what moves (MuJoCo's GEQUAL lets the later, what
        # moves, win a tie); where nothing moving was drawn its depth is the cleared 0, which
        # wins only over a backdrop as empty, of the same cleared colour
        nearer = (depth < still_depth)[..., None]
        np.copyto(colour.view(np.uint32), still_colour.view(np.uint32), where=nearer)
        from OpenGL import GL  # imported by the GL back-end, which fixed its platform

        GL.glDisable(GL.GL_DEPTH_TEST)  # mjr_render enables it again
        GL.glWindowPos2i(0, 0)
        GL.glDrawPixels(*depth.shape[::-1], GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, colour)
        return True


def _read(colour: np.ndarray, depth: np.ndarray) -> None:
    """The current framebuffer's colours (RGBA) and depths, bottom row first, read into the
    arrays (PyOpenGL writes into an array of the type it reads: uint8 for RGBA)."""
    from OpenGL import GL

    height, width = depth.shape
    GL.glReadPixels(0, 0, width, height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, colour)
    GL.glReadPixels(0, 0, width, height, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, depth)
