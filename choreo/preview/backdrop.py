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

The frame laid over goes back to GL as a copy (a texture of the backdrop's own, blitted into
MuJoCo's offscreen framebuffer), for the overlay to be drawn over it: glDrawPixels drew it as a
textured rectangle, pixel by pixel, 8x the CPU (640x480: 0.9 against 0.1 ms a frame).
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
        self._layer: tuple[int, int] | None = None  # the GL texture and framebuffer of a frame

    @functools.cached_property
    def _buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The backdrop's colours and depths, and a frame's: made when first drawn (a camera
        that follows the robot never is). Colours are read as RGBA (a pixel is laid over as
        one uint32), which GL draws into its RGBA framebuffer without converting: RGB took 4x
        the CPU."""
        colours = [np.empty((*self._size, 4), np.uint8) for _ in range(2)]
        depths = [np.empty(self._size, np.float32) for _ in range(2)]
        return colours[0], depths[0], colours[1], depths[1]

    def draw_over(self, draw: Draw, camera: object, context: mujoco.MjrContext) -> bool:
        """Draw the frame into the GL framebuffer (``context``'s offscreen one) as ``draw`` would
        draw it whole: what moves, laid over the backdrop (drawn first if ``camera`` is
        another). False, with nothing drawn that counts, when something that moves is
        transparent."""
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
        self._copy_into(context, colour)
        return True

    def _copy_into(self, context: mujoco.MjrContext, colour: np.ndarray) -> None:
        """``colour`` (RGBA, bottom row first) copied into ``context``'s offscreen framebuffer,
        at its bottom left: uploaded to this backdrop's texture, then blitted across."""
        from OpenGL import GL  # imported by the GL back-end, which fixed its platform

        height, width = self._size
        bound = GL.glGetIntegerv(GL.GL_TEXTURE_BINDING_2D)  # MuJoCo's, given back
        if self._layer is None:
            texture = GL.glGenTextures(1)
            GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
            GL.glTexImage2D(
                GL.GL_TEXTURE_2D, 0, GL.GL_RGBA8, width, height, 0, GL.GL_RGBA,
                GL.GL_UNSIGNED_BYTE, None,
            )  # fmt: skip
            framebuffer = GL.glGenFramebuffers(1)
            GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, framebuffer)
            GL.glFramebufferTexture2D(
                GL.GL_READ_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0, GL.GL_TEXTURE_2D, texture, 0
            )
            self._layer = (texture, framebuffer)
        texture, framebuffer = self._layer
        GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
        GL.glTexSubImage2D(
            GL.GL_TEXTURE_2D, 0, 0, 0, width, height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, colour
        )
        GL.glBindTexture(GL.GL_TEXTURE_2D, bound)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, framebuffer)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, context.offFBO)
        GL.glBlitFramebuffer(
            0, 0, width, height, 0, 0, width, height, GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST
        )
        mujoco.mjr_restoreBuffer(context)  # its framebuffer bound again, to draw and read

    def free(self) -> None:
        """Free the GL texture and framebuffer (the GL context current), if any was made."""
        if self._layer is not None:
            from OpenGL import GL

            texture, framebuffer = self._layer
            GL.glDeleteFramebuffers(1, [framebuffer])
            GL.glDeleteTextures([texture])
            self._layer = None


def _read(colour: np.ndarray, depth: np.ndarray) -> None:
    """The current framebuffer's colours (RGBA) and depths, bottom row first, read into the
    arrays (PyOpenGL writes into an array of the type it reads: uint8 for RGBA)."""
    from OpenGL import GL

    height, width = depth.shape
    GL.glReadPixels(0, 0, width, height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, colour)
    GL.glReadPixels(0, 0, width, height, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, depth)
