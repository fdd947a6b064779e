"""Where the simulation starts: the robot at rest in its start pose, as it would be before the
player's approach. A fixed robot simply holds the pose; a free-floating one is turned as its
motion's ``start:`` says and put down with its lowest geometry on the floor.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from choreo.motion.scene import StartPosture
from choreo.preview.model import HOME_KEY, JointIndex, free_joint, link_of_body, robot_body_mask

FOOT_CLEARANCE_M = 0.002  # a link this close to the floor standing at home is a foot
SEARCH_M = 10.0  # farthest any geom is looked for below the robot


def start_state(
    model: mujoco.MjModel,
    index: JointIndex,
    initial_deg: np.ndarray,
    posture: StartPosture = StartPosture.STANDING,
) -> mujoco.MjData:
    """The MJCF's ``home`` keyframe with the robot's joints at ``initial_deg`` and the servos
    holding them; a free-floating robot turned for ``posture`` and standing on the floor."""
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    data.qpos[index.qpos] = np.radians(initial_deg)
    data.qvel[:] = 0.0
    data.ctrl[index.actuator] = np.radians(initial_deg)
    root = free_joint(model)
    if root is not None:
        address = model.jnt_qposadr[root]
        data.qpos[address + 3 : address + 7] = _pitched(
            data.qpos[address + 3 : address + 7], posture.pitch_deg
        )
        mujoco.mj_forward(model, data)
        clearance = lowest_clearance_m(model, data)
        if clearance is not None:
            data.qpos[address + 2] -= clearance
    mujoco.mj_forward(model, data)
    return data


def _pitched(quat: np.ndarray, pitch_deg: float) -> np.ndarray:
    """``quat`` (w, x, y, z) turned by ``pitch_deg`` about the world y axis."""
    if not pitch_deg:
        return quat
    half = np.radians(pitch_deg) / 2
    turn = np.array([np.cos(half), 0.0, np.sin(half), 0.0])
    out = np.empty(4)
    mujoco.mju_mulQuat(out, turn, np.asarray(quat, dtype=float))
    return out


def floor_geoms(model: mujoco.MjModel) -> np.ndarray:
    """The world's planes: what the robot stands on at the start."""
    return np.flatnonzero(
        (model.geom_bodyid == 0) & (model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)
    )


def _colliding_robot_geoms(model: mujoco.MjModel) -> np.ndarray:
    return np.flatnonzero(
        robot_body_mask(model)[model.geom_bodyid]
        & ((model.geom_contype | model.geom_conaffinity) != 0)
    )


def clearances_m(model: mujoco.MjModel, data: mujoco.MjData) -> dict[int, float]:
    """Each colliding robot geom's distance to the nearest floor plane (negative: inside it)."""
    floors = floor_geoms(model)
    out = {}
    for geom in _colliding_robot_geoms(model):
        out[int(geom)] = min(
            (
                mujoco.mj_geomDistance(model, data, int(geom), int(f), SEARCH_M, None)
                for f in floors
            ),
            default=SEARCH_M,
        )
    return out


def lowest_clearance_m(model: mujoco.MjModel, data: mujoco.MjData) -> float | None:
    """How far the robot's lowest geometry is above the floor; None without a floor."""
    if not len(floor_geoms(model)):
        return None
    return min(clearances_m(model, data).values(), default=None)


def foot_links(
    model: mujoco.MjModel, index: JointIndex, home_deg: Sequence[float] | None
) -> tuple[int, ...]:
    """The links a free-floating robot stands on: those touching the floor when it stands in
    its home pose (none known without a home pose or a floor)."""
    if home_deg is None or not len(floor_geoms(model)):
        return ()
    data = start_state(model, index, np.asarray(home_deg, dtype=float))
    links = link_of_body(model)
    touching = {
        int(links[model.geom_bodyid[geom]])
        for geom, clearance in clearances_m(model, data).items()
        if clearance <= FOOT_CLEARANCE_M
    }
    return tuple(sorted(touching))
