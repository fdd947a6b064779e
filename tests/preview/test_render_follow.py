"""A robot that walks far is framed on its own, by a camera that follows it; one that stays (or
is fixed) keeps the one camera that frames everything it sweeps."""

from __future__ import annotations

import mujoco
import numpy as np
from paths import REPO
from render_helpers import mujoco_view
from shipped_helpers import simulated_shipped

from choreo.preview.model import load_model
from choreo.preview.render import frame_camera, frame_cameras


def robot_in_view(model, rollout, camera, step: int, aspect: float):
    """The robot's geom centres at ``step`` in the camera's picture: (x, y) at unit depth."""
    pos, right, up, forward, half_w, half_h = mujoco_view(model, camera, aspect)
    data = mujoco.MjData(model)
    data.qpos[:] = rollout.qpos[step]
    mujoco.mj_kinematics(model, data)
    seen = data.geom_xpos[model.geom_bodyid != 0] - pos
    depth = seen @ forward
    assert (depth > 0).all()
    return (seen @ right) / depth / half_w, (seen @ up) / depth / half_h


def test_a_long_walk_is_followed_with_the_robot_filling_the_picture():
    """walk_forward goes 22 cm, half the hexapod's own length: framing the whole path left its
    geoms spanning ~54 % of the picture's width; followed, over 65 % at every frame, in view."""
    walk = REPO / "motions" / "hexapod18" / "walk_forward.yaml"
    rollout = simulated_shipped(walk).rollout
    model = load_model(rollout.robot, rollout.props)
    steps = np.linspace(0, len(rollout.times_s) - 1, 8).astype(int)
    cameras = frame_cameras(model, rollout, 4 / 3, steps)
    whole = frame_camera(model, rollout, 4 / 3)
    assert cameras[0].distance < whole.distance / 1.15
    assert cameras[-1].lookat[0] - cameras[0].lookat[0] > 0.15  # it follows the walk forward
    for camera, step in zip(cameras, steps):
        x, y = robot_in_view(model, rollout, camera, int(step), 4 / 3)
        assert np.abs(x).max() <= 1 and np.abs(y).max() <= 1
        assert (x.max() - x.min()) / 2 > 0.65


def test_a_robot_that_stays_keeps_one_camera():
    for path in ("arm6/wave.yaml", "hexapod18/stand_up.yaml"):
        rollout = simulated_shipped(REPO / "motions" / path).rollout
        model = load_model(rollout.robot, rollout.props)
        steps = np.array([0, len(rollout.times_s) // 2, len(rollout.times_s) - 1])
        assert (
            frame_cameras(model, rollout, 4 / 3, steps) == [frame_camera(model, rollout, 4 / 3)] * 3
        )
