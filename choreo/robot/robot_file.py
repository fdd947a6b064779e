"""Reading robot.yaml into a validated ``Robot``: every problem in the file, and in the MuJoCo model
it names (``choreo.robot.model_check``), reported at once with its line."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

import yaml

from choreo.bus.protocol import MAX_SERVO_ID
from choreo.bus.servo_models import (
    DEG_PER_UNIT,
    MAX_RESPONSE_DELAY_S,
    POSITION_RANGE_UNITS,
    SERVO_MODELS,
    SIGNED_ACTUATOR_FIELDS,
    ZERO_OK_ACTUATOR_FIELDS,
    ServoModel,
)
from choreo.bus.settings import MAX_RETRIES, MAX_TIMEOUT_MS, BusSettings
from choreo.core.arguments import check_path
from choreo.core.file_kind import not_a_file
from choreo.core.file_shape import choices, mapping_shape
from choreo.core.yaml_source import (
    Entry,
    Node,
    Problems,
    Reader,
    SourceLocation,
    did_you_mean,
    fmt,
    parse_yaml_file,
    reading_a_file,
)
from choreo.errors import SourceError
from choreo.robot.check_cache import check_key, remember, remembered
from choreo.robot.joint_source import JointSource
from choreo.robot.lookup import ROBOT_FILE, find_robot_file
from choreo.robot.servo_figures import (
    ServoFigures,
    read_gait_compensation,
    read_servo_figures,
)
from choreo.robot.types import (
    GaitCompensation,
    Joint,
    JointLimits,
    MirrorPair,
    Robot,
    deg_to_units,
    units_to_deg,
)

VELOCITY_SHARE = 0.8  # of the no-load speed: the planner's velocity limit (servo_models)

# The keys of each mapping, from the JSON Schema (the one description of the file's shape).
ROBOT = mapping_shape("robot")
JOINT = mapping_shape("robot", "#/properties/joints/additionalProperties")
DEFAULTS = mapping_shape("robot", "#/$defs/jointSettings")  # a joint's keys but its own id
BUS = mapping_shape("robot", "#/properties/bus")  # the baud rate is always 115200
ECHO_MODES = choices("robot", "#/properties/bus/properties/echo")
MIRROR_PAIR = mapping_shape("robot", "#/properties/mirror/items")
ACTUATOR = mapping_shape("robot", "#/$defs/jointSettings/properties/actuator")
# Required once the defaults are merged in (a shape the schema cannot say: they may come from
# either), with what each is for.
REQUIRED_JOINT_KEYS = {
    "id": f"its servo id, 0..{MAX_SERVO_ID}",
    "servo": "the servo model; give it here or under defaults",
    "min": "the lower joint limit in degrees",
    "max": "the upper joint limit in degrees",
}
RATE_KEYS = ("velocity", "acceleration", "jerk")
TRAVEL_SLACK_UNITS = 1e-6  # float noise when a limit lands exactly on 0 or 1000


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
    try:
        path = find_robot_file(ref, relative_to)
    except LookupError as error:
        raise SourceError(str(error)) from None
    problems = Problems()
    with reading_a_file():
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
    bus = _read_bus(reader, fields["bus"]) if "bus" in fields else BusSettings()
    defaults = {}
    if "defaults" in fields:
        defaults = reader.fields(fields["defaults"].value, "defaults", DEFAULTS.keys) or {}
    sources = (
        _read_joints(reader, fields["joints"], defaults, bus.supply_v) if "joints" in fields else []
    )
    joints = {source.name: source.joint for source in sources}
    poses = _read_poses(reader, fields["poses"], joints) if "poses" in fields else {}
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


def _read_bus(reader: Reader, entry: Entry) -> BusSettings:
    fields = reader.fields(entry.value, "bus", BUS.keys) or {}
    # A refused value is reported (so the robot is refused too); its default stands in for it.
    default = BusSettings()
    port = default.port
    if "port" in fields:
        port = reader.string(fields["port"].value, "bus: port", optional=True)
    timeout_ms = None
    if "timeout_ms" in fields:
        timeout_ms = reader.number(
            fields["timeout_ms"].value,
            "bus: timeout_ms",
            low=0,
            high=MAX_TIMEOUT_MS,
            low_open=True,
        )
    retries = None
    if "retries" in fields:
        retries = reader.integer(fields["retries"].value, "bus: retries", low=0, high=MAX_RETRIES)
    echo = None
    if "echo" in fields:
        echo = reader.choice(fields["echo"].value, "bus: echo", ECHO_MODES)
    supply_v = None
    if "supply_v" in fields:
        supply_v = reader.number(fields["supply_v"].value, "bus: supply_v", low=0, low_open=True)
    direction = None
    if "direction" in fields:
        direction = _read_direction(reader, fields["direction"].value)
    return BusSettings(
        port=port,
        timeout_s=default.timeout_s if timeout_ms is None else timeout_ms / 1000,
        retries=default.retries if retries is None else retries,
        echo=default.echo if echo is None else echo,
        supply_v=supply_v,
        direction=direction,
    )


def _read_direction(reader: Reader, node: Node) -> str | None:
    from choreo.bus.transports.direction import (
        parse_direction,  # no GPIO library is imported by this
    )

    text = reader.string(node, "bus: direction", optional=True)
    if text is not None:
        try:
            parse_direction(text)
        except ValueError as error:
            reader.report(node, f"bus: direction: {error}")
            return None
    return text


def _read_joints(
    reader: Reader, entry: Entry, defaults: dict[str, Entry], supply_v: float | None
) -> list[JointSource]:
    """The joints; ``supply_v``: the bus's (its servos' default velocity limits scale with
    it)."""
    sources: list[JointSource] = []
    used_ids: dict[int, JointSource] = {}
    for joint_entry in reader.entries(entry.value, "joints") or []:
        source = _read_joint(reader, joint_entry, defaults, supply_v)
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


def _read_joint(
    reader: Reader, entry: Entry, defaults: dict[str, Entry], supply_v: float | None
) -> JointSource:
    own = reader.fields(entry.value, f"joint {entry.key!r}", JOINT.keys)
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
        joint = _joint_from_fields(reader, entry.key, fields, labels, supply_v)
    return JointSource(entry.key, entry.key_node, fields, joint)


def _joint_from_fields(
    reader: Reader,
    name: str,
    fields: dict[str, Entry],
    labels: dict[str, str],
    supply_v: float | None,
) -> Joint | None:
    def number(
        key: str,
        default: float | None,
        *,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
    ) -> float | None:
        if key not in fields:
            return default
        return reader.number(fields[key].value, labels[key], low=low, high=high, low_open=low_open)

    servo_id = reader.integer(fields["id"].value, labels["id"], low=0, high=MAX_SERVO_ID)
    model = _read_servo_model(reader, fields["servo"].value, labels["servo"])
    zero = number("zero", 500.0, low=POSITION_RANGE_UNITS[0], high=POSITION_RANGE_UNITS[1])
    direction = (
        _read_sign(reader, fields["direction"].value, labels["direction"])
        if "direction" in fields
        else 1
    )
    low, high = number("min", None), number("max", None)
    if low is not None and high is not None and low >= high:  # said even if other values fail
        reader.report(
            fields["min"].value, f"joint {name!r}: min {fmt(low)}° must be below max {fmt(high)}°"
        )
        low = None
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
    if (
        servo_id is None
        or model is None
        or zero is None
        or direction is None
        or low is None
        or high is None
        or mjcf_joint is None
        or actuator is None
        or any(rates[key] is None for key in RATE_KEYS if key in fields)
    ):
        return None
    # rates are > 0 when given; the servo model's defaults otherwise, its speed at the supply
    # the file declares and with the no-load speed it gives (the preview's servo is that fast)
    default_velocity = model.vel_limit_at(
        actuator.get("supply_v", supply_v), actuator.get("no_load_speed_deg_s")
    )
    limits = JointLimits(
        low,
        high,
        rates["velocity"] or default_velocity,
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
    """Preview actuator overrides: each a number > 0 (dead band, backlash, friction and delay
    >= 0, the offset of any sign; a problem makes the whole block None)."""
    entries = reader.fields(node, what, ACTUATOR.keys)
    if entries is None:
        return None
    values = {
        key: reader.number(
            entry.value,
            f"{what}: {key}",
            low=None if key in SIGNED_ACTUATOR_FIELDS else 0,
            high=MAX_RESPONSE_DELAY_S if key == "response_delay_s" else None,
            low_open=key not in ZERO_OK_ACTUATOR_FIELDS,
        )
        for key, entry in entries.items()
    }
    return _all_given(values)


def _all_given(values: Mapping[str, float | None]) -> dict[str, float] | None:
    """``values`` when none of them was refused (None), else None."""
    given = {key: value for key, value in values.items() if value is not None}
    return given if len(given) == len(values) else None


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
    """Both limits (min < max, checked as they are read) map to servo positions inside the
    servo's range."""
    first, last = POSITION_RANGE_UNITS
    reach = sorted(units_to_deg(position, zero, direction) for position in POSITION_RANGE_UNITS)
    ok = True
    for key, angle in (("min", low), ("max", high)):
        units = deg_to_units(angle, zero, direction)
        if not first - TRAVEL_SLACK_UNITS <= units <= last + TRAVEL_SLACK_UNITS:
            reader.report(
                fields[key].value,
                f"joint {name!r}: {key} {fmt(angle)}° is outside the servo's travel: it "
                f"needs servo position {units:.1f}, outside {first}..{last} "
                f"({fmt(first * DEG_PER_UNIT)}..{fmt(last * DEG_PER_UNIT)}°); with "
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
        elif (given := _all_given(angles)) is not None:
            poses[pose.key] = MappingProxyType({name: given[name] for name in joints})
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
        fields = reader.fields(item, "a mirror pair", MIRROR_PAIR.keys, MIRROR_PAIR.required)
        if fields is None or any(key not in fields for key in MIRROR_PAIR.required):
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
