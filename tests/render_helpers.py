"""MuJoCo's own view of a camera, to check where choreo's renders look from."""

from __future__ import annotations

import math

import mujoco
import numpy as np


def mujoco_view(model, camera, aspect: float):
    """MuJoCo's own camera for a pose (mjv_updateScene): position, axes and the frustum's half
    width and height at unit depth."""
    scene = mujoco.MjvScene(model, maxgeom=10)
    free = mujoco.MjvCamera()
    free.type = mujoco.mjtCamera.mjCAMERA_FREE
    free.lookat[:], free.distance = camera.lookat, camera.distance
    free.azimuth, free.elevation = camera.azimuth, camera.elevation
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mujoco.mjv_updateScene(
        model, data, mujoco.MjvOption(), None, free, mujoco.mjtCatBit.mjCAT_ALL, scene
    )
    gl = scene.camera[0]
    forward, up = np.array(gl.forward), np.array(gl.up)
    half_height = math.tan(math.radians(model.vis.global_.fovy) / 2)
    return np.array(gl.pos), np.cross(forward, up), up, forward, half_height * aspect, half_height
