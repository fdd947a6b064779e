"""Every robot in models/ and every motion in motions/, checked in MuJoCo.

Each model folder: the scene compiles and steps 1 s holding ``home`` without warnings; the
``home`` keyframe (and any other named after a pose) is robot.yaml's pose; home holds (a
free-floating robot stays up); nothing touches in home except feet on the floor; and mirroring a
pose with robot.yaml's mirror pairs mirrors the model. Each motion: no self-collision at its
keyframes or on the straight joint-space paths between them (and no floor contact for a
fixed-base robot).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from paths import REPO
from shipped_helpers import SHIPPED_MOTIONS, loaded_shipped

from choreo.robot.robot_file import load_robot

MODEL_DIRS = sorted(path.parent for path in (REPO / "models").glob("*/robot.yaml"))
MOTION_FILES = SHIPPED_MOTIONS
MIRRORED_DIRS = [
    d for d in MODEL_DIRS if yaml.safe_load((d / "robot.yaml").read_text()).get("mirror")
]
FOOT_SUFFIX = "_foot"  # geoms named so are the only ones meant to touch the floor
PATH_SAMPLES = 4  # poses checked between two keyframes


def test_the_examples_are_there():
    assert {d.name for d in MODEL_DIRS} >= {"arm6", "hexapod18"}
    assert len([m for m in MOTION_FILES if m.parent.name == "arm6"]) >= 4
    assert len([m for m in MOTION_FILES if m.parent.name == "hexapod18"]) >= 3


# --- helpers ------------------------------------------------------------------------------------


@functools.cache
def robot_file(model_dir: Path) -> dict:
    """robot.yaml read plainly (not through choreo's loader, which is not under test here)."""
    return yaml.safe_load((model_dir / "robot.yaml").read_text())


def mjcf_joint_of(model_dir: Path) -> dict[str, str]:
    joints = robot_file(model_dir)["joints"]
    return {name: (fields or {}).get("mjcf_joint", name) for name, fields in joints.items()}


@functools.cache
def scene_model(model_dir: Path) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(
        str(model_dir / robot_file(model_dir).get("scene", "scene.xml"))
    )


def is_free_floating(model: mujoco.MjModel) -> bool:
    return any(model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE for j in range(model.njnt))


def home_data(model_dir: Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The scene at its ``home`` keyframe, with every actuator holding robot.yaml's home pose."""
    model = scene_model(model_dir)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    home = robot_file(model_dir)["poses"]["home"]
    for joint, mjcf_joint in mjcf_joint_of(model_dir).items():
        data.ctrl[model.actuator(mjcf_joint).id] = math.radians(home[joint])
    mujoco.mj_forward(model, data)
    return model, data


def set_joint_angles(
    model: mujoco.MjModel, data: mujoco.MjData, angles_deg: dict[str, float]
) -> None:
    """Set MJCF joints (by name) and the joints geared to them by <equality joint>, then
    recompute positions and contacts."""
    for name, angle_deg in angles_deg.items():
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = math.radians(angle_deg)
    for eq in range(model.neq):
        if model.eq_type[eq] == mujoco.mjtEq.mjEQ_JOINT and model.eq_active0[eq]:
            follower, leader = (
                model.jnt_qposadr[model.eq_obj1id[eq]],
                model.jnt_qposadr[model.eq_obj2id[eq]],
            )
            coefficients = model.eq_data[eq, :5]
            data.qpos[follower] = sum(
                c * data.qpos[leader] ** k for k, c in enumerate(coefficients)
            )
    mujoco.mj_forward(model, data)


def body_name(model: mujoco.MjModel, body_id: int) -> str:
    return model.body(body_id).name or "world"


def self_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> list[tuple[str, str]]:
    """Touching pairs of robot bodies that are not joined to each other (floor excluded)."""
    pairs = []
    for contact in data.contact[: data.ncon]:
        a, b = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
        if 0 in (a, b) or model.body_parentid[a] == b or model.body_parentid[b] == a:
            continue
        pairs.append((body_name(model, a), body_name(model, b)))
    return pairs


def floor_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, float]:
    """Robot geom name (or its body's name) -> contact distance, for geoms touching the world."""
    touching = {}
    for contact in data.contact[: data.ncon]:
        geoms = (contact.geom1, contact.geom2)
        bodies = [model.geom_bodyid[g] for g in geoms]
        if bodies.count(0) == 1:
            geom = geoms[bodies.index(0) ^ 1]
            name = model.geom(geom).name or f"a geom of {body_name(model, model.geom_bodyid[geom])}"
            touching[name] = min(touching.get(name, math.inf), contact.dist)
    return touching


# --- every model --------------------------------------------------------------------------------


@pytest.mark.parametrize("model_dir", MODEL_DIRS, ids=lambda d: d.name)
def test_scene_steps_one_second_at_home_without_warnings(model_dir):
    model, data = home_data(model_dir)
    mujoco.mj_step(model, data, nstep=round(1.0 / model.opt.timestep))
    warnings = {
        name: data.warning[int(value)].number
        for name, value in mujoco.mjtWarning.__members__.items()
        if name != "mjNWARNING"
    }
    assert not any(warnings.values()), warnings
    assert np.isfinite(data.qpos).all()


@pytest.mark.parametrize("model_dir", MODEL_DIRS, ids=lambda d: d.name)
def test_keyframes_named_after_poses_hold_those_poses(model_dir):
    """``home`` must exist; any other keyframe named after a robot.yaml pose must match it too."""
    model = scene_model(model_dir)
    poses = robot_file(model_dir)["poses"]
    keys = [model.key(k) for k in range(model.nkey) if model.key(k).name in poses]
    assert "home" in [key.name for key in keys]
    for key in keys:
        for joint, mjcf_joint in mjcf_joint_of(model_dir).items():
            wanted = math.radians(poses[key.name][joint])
            assert key.qpos[model.jnt_qposadr[model.joint(mjcf_joint).id]] == pytest.approx(
                wanted, abs=1e-3
            ), (key.name, joint)
            assert key.ctrl[model.actuator(mjcf_joint).id] == pytest.approx(wanted, abs=1e-3), (
                key.name,
                joint,
            )


@pytest.mark.parametrize("model_dir", MODEL_DIRS, ids=lambda d: d.name)
def test_the_loader_accepts_the_robot(model_dir):
    robot = load_robot(model_dir / "robot.yaml")
    assert robot.name == model_dir.name
    assert robot.free_floating == is_free_floating(scene_model(model_dir))


@pytest.mark.parametrize("model_dir", MODEL_DIRS, ids=lambda d: d.name)
def test_home_pose_holds_for_one_second(model_dir):
    model, data = home_data(model_dir)
    start_qpos = data.qpos.copy()
    mujoco.mj_step(model, data, nstep=round(1.0 / model.opt.timestep))
    for joint, mjcf_joint in mjcf_joint_of(model_dir).items():
        address = model.jnt_qposadr[model.joint(mjcf_joint).id]
        assert abs(math.degrees(data.qpos[address] - start_qpos[address])) < 5, joint
    if is_free_floating(model):
        assert abs(data.qpos[2] - start_qpos[2]) < 0.02  # body height, m
        body_up = data.xmat[model.jnt_bodyid[0]].reshape(3, 3)[:, 2]
        assert math.degrees(math.acos(body_up[2])) < 3  # tilt
        assert np.linalg.norm(data.qpos[:2] - start_qpos[:2]) < 0.01  # no sliding away


@pytest.mark.parametrize("model_dir", MODEL_DIRS, ids=lambda d: d.name)
def test_nothing_touches_at_home_but_feet_on_the_floor(model_dir):
    model, data = home_data(model_dir)
    assert self_contacts(model, data) == []
    on_floor = floor_contacts(model, data)
    assert all(name.endswith(FOOT_SUFFIX) for name in on_floor), on_floor
    if is_free_floating(model):
        feet = [
            model.geom(g).name
            for g in range(model.ngeom)
            if model.geom(g).name.endswith(FOOT_SUFFIX)
        ]
        assert len(feet) >= 3
        # the home keyframe's height puts every foot on the floor, not in it or above it
        assert sorted(on_floor) == sorted(feet)
        assert all(abs(distance) < 1e-3 for distance in on_floor.values()), on_floor


def reflect_y(points: np.ndarray) -> np.ndarray:
    return points * np.array([1.0, -1.0, 1.0])


@pytest.mark.parametrize("model_dir", MIRRORED_DIRS, ids=lambda d: d.name)
def test_mirroring_a_pose_mirrors_the_robot(model_dir):
    """A random pose and its mirror (robot.yaml mirror pairs) are reflections of each other in
    the robot's x-z plane: the signs chosen in robot.yaml fit the MJCF axes."""
    robot_yaml = robot_file(model_dir)
    pairs = robot_yaml["mirror"]
    mjcf = mjcf_joint_of(model_dir)
    rng = np.random.default_rng(7)
    limits = {name: (j["min"], j["max"]) for name, j in robot_yaml["joints"].items()}
    pose = {name: rng.uniform(low, high) for name, (low, high) in limits.items()}
    mirrored = dict(pose)
    for pair in pairs:
        mirrored[pair["right"]] = pair["sign"] * pose[pair["left"]]
        mirrored[pair["left"]] = pair["sign"] * pose[pair["right"]]

    def geom_centres(angles: dict[str, float]) -> np.ndarray:
        model = scene_model(model_dir)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        set_joint_angles(model, data, {mjcf[name]: angle for name, angle in angles.items()})
        robot_geoms = model.geom_bodyid != 0
        return data.geom_xpos[robot_geoms]

    original, reflected = geom_centres(pose), reflect_y(geom_centres(mirrored))
    nearest = np.linalg.norm(original[:, None, :] - reflected[None, :, :], axis=2).min(axis=1)
    assert nearest.max() < 1e-6


# --- every motion -------------------------------------------------------------------------------


@pytest.mark.parametrize("motion_file", MOTION_FILES, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_motion_poses_and_paths_are_free_of_collisions(motion_file):
    """Each keyframe pose, and poses on the straight joint-space path into it, touch nothing
    but the robot's own neighbours (and, for a fixed-base robot, not the floor).

    The planner's path between keyframes is close to straight in joint space; this samples it.
    """
    motion = loaded_shipped(motion_file)  # loaded once for the preview's tests too
    robot = motion.robot
    model = scene_model(robot.path.parent)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    home = np.array(robot.pose_vector("home"))
    targets = [np.array(k.targets_deg) for k in motion.keyframes]
    wraps = [targets[0]] if motion.repeat > 1 else []
    where = [str(k.where) for k in motion.keyframes] + [f"{motion.keyframes[0].where} (repeat)"]
    previous = home
    for target, place in zip([*targets, *wraps], where):
        for fraction in np.linspace(0, 1, PATH_SAMPLES + 2)[1:]:
            angles = previous + fraction * (target - previous)
            set_joint_angles(model, data, {j.mjcf_joint: a for j, a in zip(robot.joints, angles)})
            assert self_contacts(model, data) == [], f"{place} at {fraction:.0%} of the way"
            if not robot.free_floating:
                assert floor_contacts(model, data) == {}, f"{place} at {fraction:.0%} of the way"
        previous = target
