"""Robot descriptions: ``models/<name>/robot.yaml`` -> a validated ``Robot``.

Angles are degrees everywhere above the bus. A joint angle maps to a servo position by
``units = zero_units + direction * angle_deg * 1000/240``.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import mujoco
import yaml

from .errors import SourceError
from .protocol import MAX_SERVO_ID
from .servos import ACTUATOR_FIELDS, DEG_PER_UNIT, SERVO_MODELS, UNITS_PER_DEG, ServoModel
from .yamlsource import (
    Entry,
    Node,
    Problems,
    Reader,
    SourceLocation,
    did_you_mean,
    fmt,
    parse_yaml_file,
)


@dataclass(frozen=True)
class JointLimits:
    min_deg: float
    max_deg: float
    vel_deg_s: float
    acc_deg_s2: float
    jerk_deg_s3: float

    def contains(self, angle_deg: float) -> bool:
        return self.min_deg <= angle_deg <= self.max_deg

    @property
    def range_text(self) -> str:
        """The position range for messages: ``-90..90°``."""
        return f"{fmt(self.min_deg)}..{fmt(self.max_deg)}°"


@dataclass(frozen=True)
class Joint:
    name: str
    servo_id: int
    servo_model: str  # a key of choreo.servos.SERVO_MODELS
    zero_units: float  # servo position at joint angle 0
    direction: int  # +1 or -1
    limits: JointLimits
    mjcf_joint: str  # the MuJoCo joint this servo drives
    # preview actuator values overriding the servo model's (keys: servos.ACTUATOR_FIELDS)
    actuator: Mapping[str, float] = field(default_factory=dict, hash=False)  # (a dict can't hash)

    def __post_init__(self) -> None:
        object.__setattr__(self, "actuator", MappingProxyType(dict(self.actuator)))

    def to_units(self, angle_deg: float) -> float:
        """Servo position (not rounded) for a joint angle."""
        return self.zero_units + self.direction * angle_deg * UNITS_PER_DEG

    def to_deg(self, position_units: float) -> float:
        """Joint angle for a servo position."""
        return (position_units - self.zero_units) * self.direction * DEG_PER_UNIT


@dataclass(frozen=True)
class MirrorPair:
    left: str
    right: str
    sign: int  # right = sign * left (and left = sign * right)


# The ranges the command line and the robot file's ``bus:`` section both accept. A servo answers
# within milliseconds; a read waiting longer than MAX_TIMEOUT_MS is a dead link, not a slow one.
MAX_RETRIES = 9
MAX_TIMEOUT_MS = 5000.0


@dataclass(frozen=True)
class BusSettings:
    port: str | None = None  # None: the built-in emulated bus
    timeout_s: float = 0.05
    retries: int = 2
    echo: str = "auto"  # none | discard | auto


@dataclass(frozen=True)
class Robot:
    name: str
    path: Path  # robot.yaml
    joints: tuple[Joint, ...]
    poses: Mapping[str, Mapping[str, float]]  # pose name -> joint name -> degrees (all joints)
    mirror_pairs: tuple[MirrorPair, ...] = ()
    bus: BusSettings = field(default_factory=BusSettings)
    mjcf_path: Path | None = None  # models/<name>/<name>.xml
    scene_path: Path | None = None  # models/<name>/scene.xml
    free_floating: bool = False  # the MJCF root body has a free joint

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", MappingProxyType(dict(self.poses)))

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def pose_vector(self, pose: str) -> tuple[float, ...]:
        """A named pose as degrees in joint order."""
        values = self.poses[pose]
        return tuple(values[j.name] for j in self.joints)


# --- finding a robot file ----------------------------------------------------------------------

ROBOT_FILE = "robot.yaml"
REPO_MODELS = Path(__file__).resolve().parents[1] / "models"


def is_robot_path(ref: str | Path) -> bool:
    """A reference with a folder part or a .yaml ending is a path; anything else is a name."""
    text = str(ref)
    return (
        isinstance(ref, Path) or "/" in text or os.sep in text or text.endswith((".yaml", ".yml"))
    )


def robot_search_dirs(start: Path) -> list[Path]:
    """The existing ``models`` folders searched for a robot name, in order: ``start`` and its
    parents, then each folder of ``$CHOREO_MODELS`` (os.pathsep-separated), then the repo's."""
    start = start.resolve()
    candidates = [folder / "models" for folder in (start, *start.parents)]
    candidates += [Path(p) for p in os.environ.get("CHOREO_MODELS", "").split(os.pathsep) if p]
    candidates.append(REPO_MODELS)
    found: list[Path] = []
    for folder in candidates:
        if folder.is_dir() and folder.resolve() not in found:
            found.append(folder.resolve())
    return found


def known_robots(search_dirs: list[Path]) -> list[str]:
    return sorted({p.parent.name for folder in search_dirs for p in folder.glob(f"*/{ROBOT_FILE}")})


def find_robot_file(ref: str | Path, relative_to: Path | None = None) -> Path:
    """The robot.yaml that ``ref`` names; ``LookupError`` saying what was searched otherwise.

    ``relative_to`` is the file that names the robot (a motion file): a path is relative to its
    folder, and a name is searched from its folder up. Without it, from the working directory.
    """
    base = relative_to.parent if relative_to is not None else Path()
    if is_robot_path(ref):
        path = Path(os.path.normpath(base / ref))  # "parts/../models/x" reads badly in messages
        path = path / ROBOT_FILE if path.is_dir() else path
        if not path.is_file():
            raise LookupError(f"robot file {str(ref)!r} not found (looked for {path})")
        return path
    search_dirs = robot_search_dirs(base)
    for folder in search_dirs:
        if (folder / ref / ROBOT_FILE).is_file():
            return folder / ref / ROBOT_FILE
    known = known_robots(search_dirs)
    raise LookupError(
        f"unknown robot {ref!r}{did_you_mean(ref, known)}; known robots: "
        f"{', '.join(known) or 'none'} (looked for <name>/{ROBOT_FILE} in "
        f"{', '.join(map(str, search_dirs)) or 'no models folder'}; "
        f"set CHOREO_MODELS to add a folder, or give a path to a {ROBOT_FILE})"
    )


# --- reading robot.yaml ------------------------------------------------------------------------

ROBOT_KEYS = ("name", "mjcf", "scene", "bus", "defaults", "joints", "poses", "mirror")
JOINT_KEYS = (
    "id",
    "servo",
    "zero",
    "direction",
    "min",
    "max",
    "velocity",
    "acceleration",
    "jerk",
    "mjcf_joint",
    "actuator",
)
DEFAULT_KEYS = JOINT_KEYS[1:]  # every joint needs its own id
REQUIRED_JOINT_KEYS = {
    "id": f"its servo id, 0..{MAX_SERVO_ID}",
    "servo": "the servo model; give it here or under defaults",
    "min": "the lower joint limit in degrees",
    "max": "the upper joint limit in degrees",
}
BUS_KEYS = ("port", "timeout_ms", "retries", "echo")  # the baud rate is always 115200
ECHO_MODES = ("none", "discard", "auto")
MIRROR_KEYS = ("left", "right", "sign")
RATE_KEYS = ("velocity", "acceleration", "jerk")
TRAVEL_SLACK_UNITS = 1e-6  # float noise when a limit lands exactly on 0 or 1000


def load_robot(path_or_name: str | Path, *, relative_to: Path | None = None) -> Robot:
    """Read and check a robot: by name (see ``find_robot_file``) or by path to its robot.yaml.

    Every problem found in the file and its MJCF is reported at once in one ``SourceError``.
    """
    try:
        path = find_robot_file(path_or_name, relative_to)
    except LookupError as error:
        raise SourceError(str(error)) from None
    problems = Problems()
    robot = _read_robot(Reader(path, problems), parse_yaml_file(path))
    if robot is None or problems:
        raise SourceError(problems.messages)
    return robot


@dataclass(frozen=True)
class _JointSource:
    """A joint as written: its name's node, its entries (defaults merged in) and the result."""

    name: str
    key_node: Node
    fields: dict[str, Entry]
    joint: Joint | None  # None when one of its values was refused


def _read_robot(reader: Reader, root: Node | None) -> Robot | None:
    if root is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            "the file is empty; a robot file needs name, joints and poses",
        )
        return None
    fields = reader.fields(root, "the robot file", ROBOT_KEYS, required=("name", "joints", "poses"))
    if fields is None:
        return None
    name = _read_name(reader, fields["name"]) if "name" in fields else None
    bus = _read_bus(reader, fields["bus"]) if "bus" in fields else BusSettings()
    defaults = {}
    if "defaults" in fields:
        defaults = reader.fields(fields["defaults"].value, "defaults", DEFAULT_KEYS) or {}
    sources = _read_joints(reader, fields["joints"], defaults) if "joints" in fields else []
    joints = {source.name: source.joint for source in sources}
    poses = _read_poses(reader, fields["poses"], joints) if "poses" in fields else {}
    mirror = _read_mirror(reader, fields["mirror"], joints) if "mirror" in fields else ()
    folder_name = reader.path.resolve().parent.name
    mjcf_path = _model_file(reader, fields.get("mjcf"), f"{folder_name}.xml", "the MuJoCo model")
    scene_path = _model_file(reader, fields.get("scene"), "scene.xml", "the scene")
    free_floating = _check_mujoco(reader, mjcf_path, scene_path, sources, fields, poses)
    if reader.problems:
        return None
    return Robot(
        name=name,
        path=reader.path,
        joints=tuple(s.joint for s in sources),
        poses=poses,
        mirror_pairs=mirror,
        bus=bus,
        mjcf_path=mjcf_path,
        scene_path=scene_path,
        free_floating=free_floating,
    )


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


def _read_bus(reader: Reader, entry: Entry) -> BusSettings:
    fields = reader.fields(entry.value, "bus", BUS_KEYS) or {}
    read = {
        "port": lambda node: reader.string(node, "bus: port", optional=True),
        "timeout_ms": lambda node: reader.number(
            node, "bus: timeout_ms", low=0, high=MAX_TIMEOUT_MS, low_open=True
        ),
        "retries": lambda node: reader.integer(node, "bus: retries", low=0, high=MAX_RETRIES),
        "echo": lambda node: reader.choice(node, "bus: echo", ECHO_MODES),
    }
    values = {key: read[key](entry.value) for key, entry in fields.items()}
    if "timeout_ms" in values:
        timeout_ms = values.pop("timeout_ms")
        values["timeout_s"] = timeout_ms / 1000 if timeout_ms is not None else None
    return BusSettings(**values)


def _read_joints(reader: Reader, entry: Entry, defaults: dict[str, Entry]) -> list[_JointSource]:
    sources: list[_JointSource] = []
    used_ids: dict[int, _JointSource] = {}
    for joint_entry in reader.entries(entry.value, "joints") or []:
        source = _read_joint(reader, joint_entry, defaults)
        sources.append(source)
        if source.joint is None:
            continue
        first = used_ids.setdefault(source.joint.servo_id, source)
        if first is not source:
            first_line = first.key_node.start_mark.line + 1
            reader.report(
                source.fields["id"].value,
                f"joint {source.name!r}: servo id {source.joint.servo_id} is already "
                f"used by joint {first.name!r} (line {first_line}); each joint needs "
                f"its own id 0..{MAX_SERVO_ID}",
            )
    if isinstance(entry.value, yaml.MappingNode) and not entry.value.value:
        reader.report(entry.key_node, "joints: the robot has no joints; name at least one")
    return sources


def _read_joint(reader: Reader, entry: Entry, defaults: dict[str, Entry]) -> _JointSource:
    own = reader.fields(entry.value, f"joint {entry.key!r}", JOINT_KEYS)
    fields = {**defaults, **(own or {})}
    labels = {key: f"defaults: {key}" for key in defaults}
    labels.update({key: f"joint {entry.key!r}: {key}" for key in own or {}})
    missing = [key for key in REQUIRED_JOINT_KEYS if key not in fields]
    for key in missing:
        reader.report(
            entry.key_node, f"joint {entry.key!r} is missing {key!r} ({REQUIRED_JOINT_KEYS[key]})"
        )
    joint = None
    if own is not None and not missing:
        joint = _joint_from_fields(reader, entry.key, fields, labels)
    return _JointSource(entry.key, entry.key_node, fields, joint)


def _joint_from_fields(
    reader: Reader, name: str, fields: dict[str, Entry], labels: dict[str, str]
) -> Joint | None:
    def number(key: str, default: float | None, **bounds: float | bool) -> float | None:
        if key not in fields:
            return default
        return reader.number(fields[key].value, labels[key], **bounds)

    servo_id = reader.integer(fields["id"].value, labels["id"], low=0, high=MAX_SERVO_ID)
    model = _read_servo_model(reader, fields["servo"].value, labels["servo"])
    zero = number("zero", 500.0, low=0, high=1000)
    direction = (
        _read_sign(reader, fields["direction"].value, labels["direction"])
        if "direction" in fields
        else 1
    )
    low, high = number("min", None), number("max", None)
    mjcf_joint = (
        reader.string(fields["mjcf_joint"].value, labels["mjcf_joint"])
        if "mjcf_joint" in fields
        else name
    )
    rates = {key: number(key, None, low=0, low_open=True) for key in RATE_KEYS}
    actuator = (
        _read_actuator(reader, fields["actuator"].value, labels["actuator"])
        if "actuator" in fields
        else {}
    )
    if None in (servo_id, model, zero, direction, low, high, mjcf_joint, actuator) or any(
        rates[key] is None for key in RATE_KEYS if key in fields
    ):
        return None
    # rates are > 0 when given; the servo model's defaults otherwise
    limits = JointLimits(
        low,
        high,
        rates["velocity"] or model.vel_limit_deg_s,
        rates["acceleration"] or model.acc_limit_deg_s2,
        rates["jerk"] or model.jerk_limit_deg_s3,
    )
    checks = [
        _check_travel(reader, name, fields, low, high, zero, direction),
        _check_speed(reader, name, fields, limits.vel_deg_s, model),
    ]
    if not all(checks):
        return None
    return Joint(
        name=name,
        servo_id=servo_id,
        servo_model=model.name,
        zero_units=zero,
        direction=direction,
        limits=limits,
        mjcf_joint=mjcf_joint,
        actuator=actuator,
    )


def _read_actuator(reader: Reader, node: Node, what: str) -> dict[str, float] | None:
    """Preview actuator overrides: each a number > 0 (a problem makes the whole block None)."""
    entries = reader.fields(node, what, ACTUATOR_FIELDS)
    if entries is None:
        return None
    values = {
        key: reader.number(entry.value, f"{what}: {key}", low=0, low_open=True)
        for key, entry in entries.items()
    }
    return None if None in values.values() else values


def _read_servo_model(reader: Reader, node: Node, what: str) -> ServoModel | None:
    name = reader.string(node, what)
    if name is None:
        return None
    if name not in SERVO_MODELS:
        reader.report(
            node,
            f"{what}: unknown servo model {name!r}"
            f"{did_you_mean(name, SERVO_MODELS)}; known models: "
            f"{', '.join(SERVO_MODELS)}",
        )
        return None
    return SERVO_MODELS[name]


def _read_sign(reader: Reader, node: Node, what: str) -> int | None:
    value = reader.integer(node, what)
    if value is not None and value not in (1, -1):
        reader.report(node, f"{what} must be 1 or -1, got {value}")
        return None
    return value


def _check_travel(
    reader: Reader,
    name: str,
    fields: dict[str, Entry],
    low: float,
    high: float,
    zero: float,
    direction: int,
) -> bool:
    """min < max, and both limits map to servo positions inside 0..1000."""
    if low >= high:
        reader.report(
            fields["min"].value, f"joint {name!r}: min {fmt(low)}° must be below max {fmt(high)}°"
        )
        return False
    reach = sorted((position - zero) * direction * DEG_PER_UNIT for position in (0, 1000))
    ok = True
    for key, angle in (("min", low), ("max", high)):
        units = zero + direction * angle * UNITS_PER_DEG
        if not -TRAVEL_SLACK_UNITS <= units <= 1000 + TRAVEL_SLACK_UNITS:
            reader.report(
                fields[key].value,
                f"joint {name!r}: {key} {fmt(angle)}° is outside the servo's travel: it "
                f"needs servo position {units:.1f}, outside 0..1000 (0..240°); with "
                f"zero {fmt(zero)} and direction {direction} this joint can reach "
                f"{fmt(reach[0])}..{fmt(reach[1])}°",
            )
            ok = False
    return ok


def _check_speed(
    reader: Reader, name: str, fields: dict[str, Entry], velocity: float, model: ServoModel
) -> bool:
    if velocity <= model.no_load_speed_deg_s:
        return True
    top = fmt(model.no_load_speed_deg_s)
    reader.report(
        fields["velocity"].value,
        f"joint {name!r}: velocity {fmt(velocity)} deg/s is above the {model.name}'s "
        f"no-load speed of {top} deg/s; give at most {top} "
        f"(the default is {fmt(model.vel_limit_deg_s)})",
    )
    return False


def read_angles(
    reader: Reader, node: Node, what: str, joints: Mapping[str, Joint | None]
) -> dict[str, float | None] | None:
    """A ``joint: degrees`` mapping: each joint known and each angle inside its limits.

    A named joint whose angle was refused (reported) maps to ``None``; a joint that is itself
    ``None`` (refused while reading the robot) is not limit-checked.
    """
    entries = reader.entries(node, what)
    if entries is None:
        return None
    angles: dict[str, float | None] = {}
    for entry in entries:
        if entry.key not in joints:
            reader.report(
                entry.key_node,
                f"{what}: unknown joint {entry.key!r}"
                f"{did_you_mean(entry.key, joints)}; the robot's "
                f"joints are {', '.join(joints)}",
            )
            continue
        angle = reader.number(entry.value, f"{what}: {entry.key}")
        joint = joints[entry.key]
        if angle is not None and joint is not None and not joint.limits.contains(angle):
            reader.report(
                entry.value,
                f"{what}: {entry.key} {fmt(angle)}° is outside its limits "
                f"{joint.limits.range_text}",
            )
            angle = None
        angles[entry.key] = angle
    return angles


def _read_poses(
    reader: Reader, entry: Entry, joints: Mapping[str, Joint | None]
) -> dict[str, Mapping[str, float]]:
    """Named poses, each naming every joint (in robot joint order), inside the limits."""
    poses: dict[str, Mapping[str, float]] = {}
    pose_entries = reader.entries(entry.value, "poses")
    for pose in pose_entries or []:
        what = f"pose {pose.key!r}"
        angles = read_angles(reader, pose.value, what, joints)
        if angles is None:
            continue
        missing = [name for name in joints if name not in angles]
        if missing:
            reader.report(
                pose.key_node,
                f"{what} does not give {', '.join(missing)}; every pose names every joint",
            )
        elif None not in angles.values():
            poses[pose.key] = MappingProxyType({name: angles[name] for name in joints})
    names = [pose.key for pose in pose_entries or []]
    if pose_entries is not None and "home" not in names:
        reader.report(
            entry.key_node,
            f"poses: the 'home' pose is missing"
            f"{did_you_mean('home', names)}; it is required: motions "
            f"start from it and fill partial first poses from it",
        )
    return poses


def _read_mirror(
    reader: Reader, entry: Entry, joints: Mapping[str, Joint | None]
) -> tuple[MirrorPair, ...]:
    pairs: list[MirrorPair] = []
    paired: dict[str, Node] = {}  # joint -> its pair
    for item in reader.sequence(entry.value, "mirror") or []:
        fields = reader.fields(item, "a mirror pair", MIRROR_KEYS, required=MIRROR_KEYS)
        if fields is None or len(fields) < len(MIRROR_KEYS):
            continue
        left, right = (
            _read_joint_name(reader, fields[side].value, f"mirror: {side}", joints)
            for side in ("left", "right")
        )
        sign = _read_sign(reader, fields["sign"].value, "mirror: sign")
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
    if path.is_file():
        return path
    if entry is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            f"{what} {path} does not exist; add it beside {ROBOT_FILE}",
        )
    else:
        reader.report(entry.value, f"{what} {path} does not exist")
    return None


# --- checking the MuJoCo model against the robot file ------------------------------------------

RANGE_TOLERANCE_RAD = 0.01
HOME_TOLERANCE_RAD = 1e-3  # a keyframe written with 4 decimals in radians


def _check_mujoco(
    reader: Reader,
    mjcf_path: Path | None,
    scene_path: Path | None,
    sources: list[_JointSource],
    fields: dict[str, Entry],
    poses: Mapping[str, Mapping[str, float]],
) -> bool:
    """Check the MJCF (and that the scene compiles and holds it); True if it is free-floating."""
    model = _compile(reader, mjcf_path) if mjcf_path is not None else None
    if model is None:
        return False
    mapped = _map_mjcf_joints(reader, model, mjcf_path.name, sources)
    if "joints" in fields:
        refused = {_written_mjcf_joint(s) for s in sources if s.joint is None}
        _check_actuators(reader, model, mjcf_path.name, mapped, refused, fields["joints"].key_node)
    if "home" in poses:
        home_node = next(key for key, _ in fields["poses"].value.value if key.value == "home")
        _check_home(reader, model, mjcf_path.name, mapped, poses["home"], home_node)
    scene = _compile(reader, scene_path) if scene_path is not None else None
    if scene is not None:
        _check_scene_holds_robot(reader, scene, scene_path, model, mjcf_path.name)
    return any(
        model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
        and model.body_parentid[model.jnt_bodyid[j]] == 0
        for j in range(model.njnt)
    )


def _compile(reader: Reader, path: Path) -> mujoco.MjModel | None:
    try:
        return mujoco.MjModel.from_xml_path(str(path))
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
    reader: Reader, model: mujoco.MjModel, file: str, sources: list[_JointSource]
) -> dict[int, _JointSource]:
    """MJCF joint id -> the robot joint driving it; missing, shared or unfit joints reported."""
    mapped: dict[int, _JointSource] = {}
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
                f"already driven by joint {mapped[joint_id].name!r}",
            )
        else:
            mapped[joint_id] = source
            _check_hinge(reader, model, file, joint_id, source)
    return mapped


def _check_hinge(
    reader: Reader, model: mujoco.MjModel, file: str, joint_id: int, source: _JointSource
) -> None:
    joint = source.joint
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


def _written_mjcf_joint(source: _JointSource) -> str:
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
    mapped: dict[int, _JointSource],
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
    for joint_id, source in mapped.items():
        _check_drivers(reader, file, source, drivers[joint_id])


def _check_drivers(reader: Reader, file: str, source: _JointSource, names: list[str]) -> None:
    mjcf_joint = source.joint.mjcf_joint
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
    mapped: dict[int, _JointSource],
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
    for joint_id, source in mapped.items():
        wanted = math.radians(home[source.name])
        found = float(model.key_qpos[key_id, model.jnt_qposadr[joint_id]])
        if abs(found - wanted) > HOME_TOLERANCE_RAD:
            reader.report(
                home_node,
                f"pose 'home': {source.name} is {fmt(home[source.name])}° "
                f"({wanted:.4f} rad) but the 'home' keyframe in {file} has "
                f"{found:.4f} rad ({fmt(math.degrees(found))}°) for "
                f"{source.joint.mjcf_joint!r}; make them agree",
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


# --- mirroring ---------------------------------------------------------------------------------


def mirror_pose(robot: Robot, angles_deg: Mapping[str, float]) -> dict[str, float]:
    """A (possibly partial) pose mirrored with the robot's mirror pairs.

    For a pair, the right joint gets ``sign * left`` and the left joint ``sign * right``; a joint
    paired with itself gets ``sign * value``; joints in no pair keep their value. Only joints
    whose source was given appear in the result. Limits are not checked here.
    """
    paired = {name for pair in robot.mirror_pairs for name in (pair.left, pair.right)}
    mirrored = {name: value for name, value in angles_deg.items() if name not in paired}
    for pair in robot.mirror_pairs:
        if pair.left in angles_deg:
            mirrored[pair.right] = pair.sign * angles_deg[pair.left]
        if pair.right in angles_deg:
            mirrored[pair.left] = pair.sign * angles_deg[pair.right]
    return mirrored


def mirror_targets(robot: Robot, targets_deg: tuple[float, ...]) -> tuple[float, ...]:
    """A full target vector (robot joint order) mirrored left<->right; see ``mirror_pose``."""
    if len(targets_deg) != len(robot.joints):
        raise ValueError(
            f"targets_deg has {len(targets_deg)} values; robot {robot.name!r} has "
            f"{len(robot.joints)} joints"
        )
    mirrored = mirror_pose(robot, dict(zip(robot.joint_names, targets_deg)))
    return tuple(mirrored[name] for name in robot.joint_names)
