"""Reading robot.yaml into a validated ``Robot``: every problem in the file, and in the MuJoCo model
it names (``choreo.robot.model_check``), reported at once with its line."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

import yaml

from choreo.bus.servo_models import SERVO_MODELS
from choreo.bus.settings import BusSettings
from choreo.core.arguments import check_flag, check_path
from choreo.core.collector import collector_paused
from choreo.core.file_kind import not_a_file
from choreo.core.file_shape import mapping_shape
from choreo.core.yaml_source import (
    Entry,
    Node,
    Problems,
    Reader,
    SourceLocation,
    did_you_mean,
    parse_yaml_file,
)
from choreo.errors import SourceError
from choreo.robot.bus_entry import read_bus
from choreo.robot.check_cache import check_key, remember, remembered
from choreo.robot.joint_entry import read_joints, read_sign
from choreo.robot.joint_source import JointSource
from choreo.robot.lookup import ROBOT_FILE, find_robot_file
from choreo.robot.poses import read_poses
from choreo.robot.servo_figures import ServoFigures, read_gait_compensation, read_servo_figures
from choreo.robot.types import GaitCompensation, Joint, MirrorPair, Robot

VELOCITY_SHARE = 0.8  # of the no-load speed: the planner's velocity limit (servo_models)

# The keys of each mapping, from the JSON Schema (the one description of the file's shape).
ROBOT = mapping_shape("robot")
DEFAULTS = mapping_shape("robot", "#/$defs/jointSettings")  # a joint's keys but its own id
MIRROR_PAIR = mapping_shape("robot", "#/properties/mirror/items")


def load_robot(
    path_or_name: str | Path, *, relative_to: Path | None = None, with_figures: bool = True
) -> Robot:
    """Read and check a robot: by name (see ``find_robot_file``) or by path to its robot.yaml.

    Every problem found in the file and its MJCF is reported at once in one ``SourceError``.
    The servo figures file it names (``servo_figures:``) is applied to its joints unless not
    ``with_figures`` (``choreo identify``, which measures them anew).
    """
    path = check_path("path_or_name", path_or_name, "a robot's name or its robot.yaml's path")
    ref = path_or_name if isinstance(path_or_name, str) else path  # a name is a str
    if relative_to is not None:
        relative_to = check_path("relative_to", relative_to, "the path of the file naming it")
    with_figures = check_flag("with_figures", with_figures)
    try:
        path = find_robot_file(ref, relative_to)
    except LookupError as error:
        raise SourceError(str(error)) from None
    problems = Problems()
    with collector_paused():
        root = parse_yaml_file(path)
        robot = _read_robot(Reader(path, problems), root)
    if robot is None or problems:
        raise SourceError(problems.messages)
    figures_path = _named_figures(path, root)
    if figures_path is not None and with_figures:
        if not figures_path.is_file():
            raise SourceError(
                f"{path}: servo_figures: {figures_path} does not exist; measure the servos "
                f"(choreo identify {robot.name} -o {figures_path.name}) or remove the key"
            )
        robot = with_servo_figures(robot, read_servo_figures(figures_path, robot))
    return robot


def _named_figures(robot_path: Path, root: Node | None) -> Path | None:
    """The servo figures file the robot file names (its value checked as it was read)."""
    for key, value in root.value if isinstance(root, yaml.MappingNode) else ():
        if key.value == "servo_figures":
            return robot_path.parent / str(value.value)
    return None


def with_servo_figures(robot: Robot, figures: ServoFigures) -> Robot:
    """``robot`` with the measured figures over its joints' actuator figures, and a joint's
    planning velocity, where its robot file does not set one, 80 % of its measured speed (as
    the servo table's is of the datasheet's).

    The file's ``gait:`` compensation, if it has one, replaces the robot file's: ``choreo
    identify`` writes it, recalibrated in the preview with the measured figures
    (``preview/gait_calibration.py``), where the robot file's was tuned to the assumed ones.
    Without one the robot file's is kept as written."""
    joints = []
    for joint in robot.joints:
        measured = figures.joints.get(joint.name, {})
        limits = joint.limits
        speed = measured.get("no_load_speed_deg_s")
        if (
            speed is not None
            and limits.vel_deg_s == SERVO_MODELS[joint.servo_model].vel_limit_deg_s
        ):
            limits = dataclasses.replace(limits, vel_deg_s=VELOCITY_SHARE * speed)
        joints.append(
            dataclasses.replace(joint, actuator={**joint.actuator, **measured}, limits=limits)
        )
    gait = robot.gait if figures.gait is None else figures.gait
    return dataclasses.replace(robot, joints=tuple(joints), servo_figures=figures, gait=gait)


def _read_robot(reader: Reader, root: Node | None) -> Robot | None:
    if root is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            "the file is empty; a robot file needs name, joints and poses",
        )
        return None
    fields = reader.fields(root, "the robot file", ROBOT.keys, required=ROBOT.required)
    if fields is None:
        return None
    name = _read_name(reader, fields["name"]) if "name" in fields else None
    bus = read_bus(reader, fields["bus"]) if "bus" in fields else BusSettings()
    defaults = {}
    if "defaults" in fields:
        defaults = reader.fields(fields["defaults"].value, "defaults", DEFAULTS.keys) or {}
    sources = (
        read_joints(reader, fields["joints"], defaults, bus.supply_v) if "joints" in fields else []
    )
    joints = {source.name: source.joint for source in sources}
    poses = read_poses(reader, fields["poses"], joints) if "poses" in fields else {}
    mirror = _read_mirror(reader, fields["mirror"], joints) if "mirror" in fields else ()
    gait = (
        read_gait_compensation(reader, fields["gait"].value)
        if "gait" in fields
        else GaitCompensation()
    )
    folder_name = reader.path.resolve().parent.name
    mjcf_path = _model_file(reader, fields.get("mjcf"), f"{folder_name}.xml", "the MuJoCo model")
    if "servo_figures" in fields:
        reader.string(fields["servo_figures"].value, "servo_figures")
    scene_path = _model_file(reader, fields.get("scene"), "scene.xml", "the scene")
    free_floating = False
    if mjcf_path is not None:
        free_floating = _check_model(reader, mjcf_path, scene_path, sources, fields, poses)
    read = tuple(s.joint for s in sources if s.joint is not None)
    # The name or a joint is None only when refused, which is reported: the two tests after
    # `reader.problems` only say so to the type checker.
    if reader.problems or name is None or len(read) < len(sources):
        return None
    return Robot(
        name=name,
        path=reader.path,
        joints=read,
        poses=poses,
        mirror_pairs=mirror,
        bus=bus,
        mjcf_path=mjcf_path,
        scene_path=scene_path,
        free_floating=free_floating,
        gait=gait,
    )


def _check_model(
    reader: Reader,
    mjcf_path: Path,
    scene_path: Path | None,
    sources: list[JointSource],
    fields: dict[str, Entry],
    poses: Mapping[str, Mapping[str, float]],
) -> bool:
    """``model_check.check_model``, unless the same check passed before for these very files
    (``check_cache``): then what it found is taken without importing MuJoCo. A robot file
    with problems is always checked, so that every problem is reported at once."""
    models = [mjcf_path] if scene_path is None else [mjcf_path, scene_path]
    key = None if reader.problems else check_key(reader.path, models)
    if key is not None:
        free_floating = remembered(key)
        if free_floating is not None:
            return free_floating
    from choreo.robot.model_check import check_model  # mujoco (slow to import): only here

    free_floating = check_model(reader, mjcf_path, scene_path, sources, fields, poses)
    if key is not None and not reader.problems:
        remember(key, free_floating)
    return free_floating


def _read_name(reader: Reader, entry: Entry) -> str | None:
    name = reader.string(entry.value, "name")
    folder = reader.path.resolve().parent.name
    if name is not None and name != folder:
        reader.report(
            entry.value,
            f"name {name!r} must equal the robot's folder name {folder!r} "
            f"(robots are found by folder: models/<name>/{ROBOT_FILE})",
        )
    return name


def _read_mirror(
    reader: Reader, entry: Entry, joints: Mapping[str, Joint | None]
) -> tuple[MirrorPair, ...]:
    pairs: list[MirrorPair] = []
    paired: dict[str, Node] = {}  # joint -> its pair
    for item in reader.sequence(entry.value, "mirror") or []:
        fields = reader.fields(item, "a mirror pair", MIRROR_PAIR.keys, MIRROR_PAIR.required)
        if fields is None or any(key not in fields for key in MIRROR_PAIR.required):
            continue
        left, right = (
            _read_joint_name(reader, fields[side].value, f"mirror: {side}", joints)
            for side in ("left", "right")
        )
        sign = read_sign(reader, fields["sign"].value, "mirror: sign")
        if left is None or right is None or sign is None:
            continue
        for name in dict.fromkeys((left, right)):
            if paired.setdefault(name, item) is not item:
                reader.report(
                    item,
                    f"mirror: joint {name!r} is already in the pair at line "
                    f"{paired[name].start_mark.line + 1}; a joint belongs to at "
                    f"most one pair",
                )
        pairs.append(MirrorPair(left, right, sign))
    return tuple(pairs)


def _read_joint_name(
    reader: Reader, node: Node, what: str, joints: Mapping[str, Joint | None]
) -> str | None:
    name = reader.string(node, what)
    if name is not None and name not in joints:
        reader.report(
            node,
            f"{what}: unknown joint {name!r}{did_you_mean(name, joints)}; "
            f"the robot's joints are {', '.join(joints)}",
        )
        return None
    return name


def _model_file(reader: Reader, entry: Entry | None, default: str, what: str) -> Path | None:
    """The MJCF or scene file beside robot.yaml (or where its key says)."""
    relative = reader.string(entry.value, entry.key) if entry is not None else default
    if relative is None:
        return None
    path = reader.path.parent / relative
    kind = not_a_file(path)
    if kind is None and path.is_file():
        return path
    if kind is not None:
        where = (
            reader.where(entry.value) if entry is not None else SourceLocation(reader.path, 1, 1)
        )
        reader.problems.add(where, f"{what} {path} is {kind}, not a file")
    elif entry is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            f"{what} {path} does not exist; add it beside {ROBOT_FILE}",
        )
    else:
        reader.report(entry.value, f"{what} {path} does not exist")
    return None
