"""Cross-checks between robot.yaml and its MuJoCo model (MJCF) and scene: the one place outside the
preview that imports ``mujoco``, and only when a robot file is read
(``choreo.robot.robot_file``)."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import yaml

from choreo.core.yaml_source import Entry, Node, Reader, SourceLocation, did_you_mean, fmt
from choreo.robot.compiled_model import compiled_model
from choreo.robot.joint_source import JointSource
from choreo.robot.poses import HOME_POSE

if TYPE_CHECKING:
    from choreo.robot.types import Joint

RANGE_TOLERANCE_RAD = 0.01
HOME_TOLERANCE_RAD = 1e-3  # a keyframe written with 4 decimals in radians


@dataclass(frozen=True)
class MappedJoint:
    """A robot joint read without problems, and where it was written."""

    joint: Joint
    source: JointSource


def check_model(
    reader: Reader,
    mjcf_path: Path,
    scene_path: Path | None,
    sources: list[JointSource],
    fields: dict[str, Entry],
    poses: Mapping[str, Mapping[str, float]],
) -> bool:
    """Check the MJCF (and that the scene compiles and holds it); True if it is free-floating."""
    model = _compile(reader, mjcf_path)
    if model is None:
        return False
    mapped = _map_mjcf_joints(reader, model, mjcf_path.name, sources)
    if "joints" in fields:
        refused = {_written_mjcf_joint(s) for s in sources if s.joint is None}
        _check_actuators(reader, model, mjcf_path.name, mapped, refused, fields["joints"].key_node)
    if HOME_POSE in poses:
        home_node = next(key for key, _ in fields["poses"].value.value if key.value == HOME_POSE)
        _check_home(reader, model, mjcf_path.name, mapped, poses[HOME_POSE], home_node)
    if scene_path is not None:
        scene = _compile(reader, scene_path)
        if scene is not None:
            _check_scene_holds_robot(reader, scene, scene_path, model, mjcf_path.name)
    return any(
        model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
        and model.body_parentid[model.jnt_bodyid[j]] == 0
        for j in range(model.njnt)
    )


def _compile(reader: Reader, path: Path) -> mujoco.MjModel | None:
    try:
        return compiled_model(path)
    except ValueError as error:
        text = " ".join(str(error).split())
        line = re.search(r"line(?: number=| )(\d+)", text, re.IGNORECASE)
        reader.problems.add(
            SourceLocation(path, int(line.group(1)) if line else 1, 1),
            f"MuJoCo cannot compile this model: {text}",
        )
        return None


def _joint_names(model: mujoco.MjModel) -> list[str]:
    names = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt))
    return [name for name in names if name]


def _map_mjcf_joints(
    reader: Reader, model: mujoco.MjModel, file: str, sources: list[JointSource]
) -> dict[int, MappedJoint]:
    """MJCF joint id -> the robot joint driving it; missing, shared or unfit joints reported."""
    mapped: dict[int, MappedJoint] = {}
    for source in sources:
        joint = source.joint
        if joint is None:
            continue
        node = (
            source.fields["mjcf_joint"].value if "mjcf_joint" in source.fields else source.key_node
        )
        joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
        if joint_id < 0:
            names = _joint_names(model)
            reader.report(
                node,
                f"joint {joint.name!r}: {file} has no joint {joint.mjcf_joint!r}"
                f"{did_you_mean(joint.mjcf_joint, names)}; its joints are "
                f"{', '.join(names) or 'none'}",
            )
        elif joint_id in mapped:
            reader.report(
                node,
                f"joint {joint.name!r}: MJCF joint {joint.mjcf_joint!r} is "
                f"already driven by joint {mapped[joint_id].joint.name!r}",
            )
        else:
            mapped[joint_id] = MappedJoint(joint, source)
            _check_hinge(reader, model, file, joint_id, mapped[joint_id])
    return mapped


def _check_hinge(
    reader: Reader, model: mujoco.MjModel, file: str, joint_id: int, driver: MappedJoint
) -> None:
    joint, source = driver.joint, driver.source
    what = f"joint {joint.name!r}: MJCF joint {joint.mjcf_joint!r} in {file}"
    wanted = (math.radians(joint.limits.min_deg), math.radians(joint.limits.max_deg))
    wanted_words = f'range="{wanted[0]:.4f} {wanted[1]:.4f}"'
    if model.jnt_type[joint_id] != mujoco.mjtJoint.mjJNT_HINGE:
        kind = mujoco.mjtJoint(model.jnt_type[joint_id]).name.removeprefix("mjJNT_").lower()
        reader.report(source.key_node, f"{what} is a {kind} joint; it must be a hinge")
    elif not model.jnt_limited[joint_id]:
        reader.report(
            source.key_node,
            f"{what} has no range; give it {wanted_words} "
            f"(the limits {fmt(joint.limits.min_deg)}.."
            f"{fmt(joint.limits.max_deg)}° in radians)",
        )
    else:
        low, high = model.jnt_range[joint_id]
        if max(abs(low - wanted[0]), abs(high - wanted[1])) > RANGE_TOLERANCE_RAD:
            reader.report(
                source.fields["min"].value,
                f"{what} has range {low:.4f} {high:.4f} rad ({math.degrees(low):.1f}.."
                f"{math.degrees(high):.1f}°) but the robot file says "
                f"{fmt(joint.limits.min_deg)}..{fmt(joint.limits.max_deg)}°; make them "
                f"agree within {RANGE_TOLERANCE_RAD} rad, e.g. {wanted_words}",
            )


def _written_mjcf_joint(source: JointSource) -> str:
    """The MJCF joint a joint names, even when the joint was refused."""
    node = source.fields.get("mjcf_joint")
    return (
        node.value.value
        if node is not None and isinstance(node.value, yaml.ScalarNode)
        else source.name
    )


def _check_actuators(
    reader: Reader,
    model: mujoco.MjModel,
    file: str,
    mapped: dict[int, MappedJoint],
    refused: set[str],
    joints_node: Node,
) -> None:
    """Every actuator drives a mapped joint; every mapped joint has one, named after it.

    Actuators of joints that were refused (already reported) are not reported again.
    """
    drivers: dict[int, list[str]] = {joint_id: [] for joint_id in mapped}
    for actuator in range(model.nu):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator) or f"#{actuator}"
        joint_id = int(model.actuator_trnid[actuator, 0])
        if model.actuator_trntype[actuator] != mujoco.mjtTrn.mjTRN_JOINT:
            reader.report(
                joints_node,
                f"{file}: actuator {name!r} does not drive a joint; "
                f"each actuator must drive one joint of this list",
            )
        elif joint_id not in mapped:
            joint_name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint_id)
            if joint_name in refused:
                continue
            reader.report(
                joints_node,
                f"{file}: actuator {name!r} drives joint {joint_name!r}, "
                f"which no joint here maps; add a joint with "
                f"mjcf_joint: {joint_name}, or remove the actuator",
            )
        else:
            drivers[joint_id].append(name)
    for joint_id, driver in mapped.items():
        _check_drivers(reader, file, driver, drivers[joint_id])


def _check_drivers(reader: Reader, file: str, driver: MappedJoint, names: list[str]) -> None:
    source, mjcf_joint = driver.source, driver.joint.mjcf_joint
    what = f"joint {source.name!r}: MJCF joint {mjcf_joint!r}"
    if not names:
        reader.report(
            source.key_node, f"{what} has no actuator in {file}; add one named {mjcf_joint!r}"
        )
    elif len(names) > 1:
        reader.report(
            source.key_node,
            f"{what} has {len(names)} actuators in {file} ({', '.join(names)}); keep exactly one",
        )
    elif names[0] != mjcf_joint:
        reader.report(
            source.key_node,
            f"{what}: its actuator in {file} is named {names[0]!r}; "
            f"name it {mjcf_joint!r}, after its joint",
        )


def _check_home(
    reader: Reader,
    model: mujoco.MjModel,
    file: str,
    mapped: dict[int, MappedJoint],
    home: Mapping[str, float],
    home_node: Node,
) -> None:
    key_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key_id < 0:
        reader.report(
            home_node,
            f"pose 'home': {file} has no 'home' keyframe; add "
            f'<keyframe><key name="home" qpos="..."/></keyframe> holding '
            f"this pose in radians",
        )
        return
    for joint_id, driver in mapped.items():
        joint = driver.joint
        wanted = math.radians(home[joint.name])
        found = float(model.key_qpos[key_id, model.jnt_qposadr[joint_id]])
        if abs(found - wanted) > HOME_TOLERANCE_RAD:
            reader.report(
                home_node,
                f"pose 'home': {joint.name} is {fmt(home[joint.name])}° "
                f"({wanted:.4f} rad) but the 'home' keyframe in {file} has "
                f"{found:.4f} rad ({fmt(math.degrees(found))}°) for "
                f"{joint.mjcf_joint!r}; make them agree",
            )


def _check_scene_holds_robot(
    reader: Reader, scene: mujoco.MjModel, scene_path: Path, model: mujoco.MjModel, file: str
) -> None:
    missing = [
        name
        for name in _joint_names(model)
        if mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_JOINT, name) < 0
    ]
    if missing:
        reader.problems.add(
            SourceLocation(scene_path, 1, 1),
            f"the scene lacks the robot's joints {', '.join(missing)}; "
            f'include the robot: <include file="{file}"/>',
        )
