"""The joints of robot.yaml read and checked: each joint's servo, zero, direction, limits, rates and
actuator figures (the file's defaults merged in), every problem reported at its line."""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

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
from choreo.core.file_shape import mapping_shape
from choreo.core.yaml_source import Entry, Node, Reader, did_you_mean, fmt
from choreo.robot.joint_source import JointSource
from choreo.robot.types import Joint, JointLimits, deg_to_units, units_to_deg

# The keys of each mapping, from the JSON Schema (the one description of the file's shape).
JOINT = mapping_shape("robot", "#/properties/joints/additionalProperties")
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
T = TypeVar("T")
TRAVEL_SLACK_UNITS = 1e-6  # float noise when a limit lands exactly on 0 or 1000


def read_joints(
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
    """The joint the entries (defaults merged in) describe, or None when one of its values was
    refused (each refusal reported)."""

    def given(key: str, read: Callable[[Node, str], T | None], default: T) -> T | None:
        """``read`` of the key's entry, under its label; ``default`` when it is not given."""
        return read(fields[key].value, labels[key]) if key in fields else default

    def number(key: str, default: float | None, **bounds: Any) -> float | None:
        return given(key, functools.partial(reader.number, **bounds), default)

    servo_id = reader.integer(fields["id"].value, labels["id"], low=0, high=MAX_SERVO_ID)
    model = _read_servo_model(reader, fields["servo"].value, labels["servo"])
    zero = number("zero", 500.0, low=POSITION_RANGE_UNITS[0], high=POSITION_RANGE_UNITS[1])
    direction = given("direction", functools.partial(read_sign, reader), 1)
    low, high = number("min", None), number("max", None)
    low = _below_max(reader, name, fields, low, high)
    mjcf_joint = given("mjcf_joint", reader.string, name)
    rates = {key: number(key, None, low=0, low_open=True) for key in RATE_KEYS}
    no_overrides: dict[str, float] = {}
    actuator = given("actuator", functools.partial(_read_actuator, reader), no_overrides)
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
    limits = _joint_limits(model, low, high, rates, actuator, supply_v)
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


def _below_max(
    reader: Reader, name: str, fields: dict[str, Entry], low: float | None, high: float | None
) -> float | None:
    """``low`` (min), or None when it is not below max: said even if other values fail."""
    if low is not None and high is not None and low >= high:
        reader.report(
            fields["min"].value, f"joint {name!r}: min {fmt(low)}° must be below max {fmt(high)}°"
        )
        return None
    return low


def _joint_limits(
    model: ServoModel,
    low: float,
    high: float,
    rates: dict[str, float | None],
    actuator: dict[str, float],
    supply_v: float | None,
) -> JointLimits:
    """The joint's limits: rates are > 0 when given; the servo model's defaults otherwise, its
    speed at the supply the file declares and with the no-load speed it gives (the preview's
    servo is that fast)."""
    default_velocity = model.vel_limit_at(
        actuator.get("supply_v", supply_v), actuator.get("no_load_speed_deg_s")
    )
    return JointLimits(
        low,
        high,
        rates["velocity"] or default_velocity,
        rates["acceleration"] or model.acc_limit_deg_s2,
        rates["jerk"] or model.jerk_limit_deg_s3,
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
    return all_given(values)


def all_given(values: Mapping[str, float | None]) -> dict[str, float] | None:
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


def read_sign(reader: Reader, node: Node, what: str) -> int | None:
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
