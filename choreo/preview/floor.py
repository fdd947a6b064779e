"""The floor as the renderer draws it: a plane MuJoCo would draw as infinite, drawn finite.

MuJoCo draws an infinite plane (a size of 0) as a grid of 200 x 200 quads (``mjMAXPLANEGRID``)
reaching past the skybox, and Mesa's software renderer (llvmpipe) transforms, lights and clips
their 160,000 vertices on every frame: half of a 320x240 frame's CPU. A finite plane as wide,
in a few large quads, looks the same, pixel for pixel, wherever its quads' size changes nothing:
every light is directional (spot and point lights are lit per vertex, so a coarse grid would
show), and the plane's texture, if any, is a 2D one laid in metres (``texuniform``), whose phase
is matched to the infinite plane's by the finite plane's size. Not in the renderer's high
quality, whose haze shows the far edge move a little and whose reflection and multisampling
differ in a few pixels along the grid's lines.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

QUADS_PER_HALF = 5  # a finite plane's grid spacing: its half-size over this (6 x 6 quads)


def draw_infinite_planes_finite(model: mujoco.MjModel) -> int:
    """Give each infinite plane of ``model`` that can look the same drawn finite the size and
    grid of one as wide as MuJoCo draws it; how many planes were changed. Call it before
    ``mujoco.MjrContext(model, ...)``, which builds the planes' grids. Only for a model that is
    rendered: a finite plane collides only within its size."""
    if not (model.light_type == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL).all():
        return 0
    changed = 0
    for geom in np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE).tolist():
        size = model.geom_size[geom]
        if min(size[0], size[1]) > 0 or not _looks_the_same_finite(model, geom):
            continue
        for axis in (0, 1):
            if size[axis] <= 0:
                size[axis] = _finite_half_size(model, geom, axis)
        size[2] = max(size[0], size[1]) / QUADS_PER_HALF
        changed += 1
    return changed


def _looks_the_same_finite(model: mujoco.MjModel, geom: int) -> bool:
    """The plane has no texture, or a 2D one repeated per metre (not stretched over its size)."""
    material = model.geom_matid[geom]
    if material < 0:
        return True
    texture = model.mat_texid[material, mujoco.mjtTextureRole.mjTEXROLE_RGB]
    if texture < 0:
        return True
    is_2d = model.tex_type[texture] == mujoco.mjtTexture.mjTEXTURE_2D
    return bool(is_2d and model.mat_texuniform[material])


def _finite_half_size(model: mujoco.MjModel, geom: int, axis: int) -> float:
    """The half-size along ``axis`` at which the finite plane reaches as far as MuJoCo draws the
    infinite one (render_context.c, makePlane) and its texture lies where the infinite plane's
    does: the infinite plane's texture coordinate is ``repeat * x / 2 - 1/2``, the finite one's
    ``repeat * (x + half) / 2``, the same modulo 1 when ``repeat * half`` is odd."""
    far = model.vis.map.zfar * model.stat.extent
    material = model.geom_matid[geom]
    repeat = float(model.mat_texrepeat[material, axis]) if material >= 0 else 0.0
    step = 2 / repeat if repeat > 0 else 2.1 * far / (mujoco.mjMAXPLANEGRID - 2)
    reach = (2.1 * far + 2 * step) / 2
    repeat = repeat if repeat > 0 else 1.0  # MuJoCo's texture scale for no repeat
    odd = 2 * math.ceil((reach * repeat + 1) / 2) - 1
    return odd / repeat
