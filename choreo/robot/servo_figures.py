"""Servo figures files: each servo's actuator figures, per joint (by name) or per servo (by ID).

One format for two uses: the figures ``choreo identify`` measured on a robot (the robot file
names that file, and the preview, the planner and the gaits use it), and an emulated robot's
hidden truth (``sim://?physics=ROBOT&truth=FILE``: the servos as they really are, which
identification must find). Its keys::

    supply: {voltage_v: 7.4, resistance_ohm: 0.15}   # optional: the supply and its sag
    joints:                                          # a joint's figures, by name
      shoulder: {backlash_deg: 0.8, friction_nm: 0.02}
    servos:                                          # or by servo ID
      3: {deadband_deg: 0.5}
    gait: {lift_sag: 6, stride_scale: 1.1, turn_scale: 1.2}   # optional: a walker's gaits'
                                                     # compensation with these servos

Each joint's keys are the robot file's ``actuator:`` keys (``servo_models.ACTUATOR_FIELDS``),
``gait:``'s those of the robot file's ``gait:`` (read here for both), which it replaces.
``choreo identify`` adds what it measured and how well the figures predict it (``measured:``,
``validation:``), which the reader keeps as written.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import yaml

from choreo.bus.servo_models import (
    ACTUATOR_FIELDS,
    MAX_RESPONSE_DELAY_S,
    SIGNED_ACTUATOR_FIELDS,
    ZERO_OK_ACTUATOR_FIELDS,
)
from choreo.core.collector import collector_paused
from choreo.core.file_shape import mapping_shape
from choreo.core.yaml_source import (
    Problems,
    Reader,
    describe,
    did_you_mean,
    parse_yaml_file,
)
from choreo.errors import SourceError
from choreo.robot.types import GaitCompensation, Robot

TOP_KEYS = (
    "supply",
    "joints",
    "servos",
    "gait",
    "robot",
    "measured",
    "validation",
    "transport",
)
GAIT = mapping_shape("robot", "#/properties/gait")
# A gait's lift sag (mm) and its stride and turn scales: beyond these it is not a correction.
GAIT_BOUNDS = {"lift_sag": (0, 100), "stride_scale": (0.5, 2), "turn_scale": (0.5, 2)}
SUPPLY_KEYS = ("voltage_v", "resistance_ohm")
DEFAULT_SUPPLY_RESISTANCE_OHM = 0.1  # a bench supply and its leads: a few tenths of a volt at 2 A


@dataclass(frozen=True)
class ServoFigures:
    """What a servo figures file says: each joint's actuator figures (robot joint names), and
    the supply if it is given; ``extra`` keeps identify's own keys (``measured``, ...)."""

    path: Path
    joints: Mapping[str, Mapping[str, float]]
    supply_v: float | None = None
    supply_resistance_ohm: float = DEFAULT_SUPPLY_RESISTANCE_OHM
    extra: Mapping[str, Any] = field(default_factory=dict)
    gait: GaitCompensation | None = None  # the gaits' compensation with these servos

    def __post_init__(self) -> None:
        frozen = {name: MappingProxyType(dict(v)) for name, v in self.joints.items()}
        object.__setattr__(self, "joints", MappingProxyType(frozen))


def read_servo_figures(path: str | Path, robot: Robot) -> ServoFigures:
    """The figures in ``path`` for ``robot``'s joints; one ``SourceError`` listing every
    problem (``path:line:col``) otherwise."""
    path = Path(path)
    problems = Problems()
    with collector_paused():
        root = parse_yaml_file(path)
        reader = Reader(path, problems)
        figures = _read(reader, root, robot) if root is not None else None
    if root is None:
        raise SourceError(
            f"{path}:1:1: the file is empty; a servo figures file needs joints: or servos:"
        )
    if figures is None or problems:
        raise SourceError(problems.messages)
    return figures


def _read(reader: Reader, root: yaml.Node, robot: Robot) -> ServoFigures | None:
    fields = reader.fields(root, "the servo figures file", TOP_KEYS)
    if fields is None:
        return None
    joints: dict[str, dict[str, float]] = {}
    if "joints" in fields:
        for entry in reader.entries(fields["joints"].value, "joints") or ():
            if entry.key not in robot.joint_names:
                reader.report(
                    entry.key_node,
                    f"joints: {robot.name} has no joint {entry.key!r}"
                    f"{did_you_mean(entry.key, robot.joint_names)}; its joints: "
                    f"{', '.join(robot.joint_names)}",
                )
                continue
            joints[entry.key] = _read_joint(reader, entry.value, f"joints: {entry.key}")
    if "servos" in fields:
        by_id = {joint.servo_id: joint.name for joint in robot.joints}
        node = fields["servos"].value
        if not isinstance(node, yaml.MappingNode):
            reader.report(node, f"servos must be a mapping of servo IDs, got {describe(node)}")
        else:
            for key_node, value in node.value:
                servo_id = _servo_id(key_node)
                name = None if servo_id is None else by_id.get(servo_id)
                if name is None:
                    reader.report(
                        key_node,
                        f"servos: {robot.name} has no servo {key_node.value!r}; its servo IDs: "
                        f"{', '.join(str(i) for i in by_id)}",
                    )
                elif name in joints:
                    reader.report(
                        key_node, f"servos: {key_node.value} is joint {name}, given twice"
                    )
                else:
                    joints[name] = _read_joint(reader, value, f"servos: {key_node.value}")
    supply_v, resistance = None, DEFAULT_SUPPLY_RESISTANCE_OHM
    if "supply" in fields:
        supply = reader.fields(fields["supply"].value, "supply", SUPPLY_KEYS) or {}
        if "voltage_v" in supply:
            supply_v = reader.number(
                supply["voltage_v"].value, "supply: voltage_v", low=0, low_open=True
            )
        if "resistance_ohm" in supply:
            resistance = (
                reader.number(supply["resistance_ohm"].value, "supply: resistance_ohm", low=0)
                or 0.0
            )
    extra = {
        key: yaml.safe_load(yaml.serialize(entry.value))
        for key, entry in fields.items()
        if key in ("robot", "measured", "transport", "validation")
    }
    gait = read_gait_compensation(reader, fields["gait"].value) if "gait" in fields else None
    return ServoFigures(reader.path, joints, supply_v, resistance, extra, gait)


def read_gait_compensation(reader: Reader, node: yaml.Node) -> GaitCompensation:
    """A ``gait: {lift_sag, stride_scale, turn_scale}`` block (a robot file's or a servo
    figures file's); a refused value is reported (so the file is refused too) and its default
    stands in for it."""
    fields = reader.fields(node, "gait", GAIT.keys) or {}
    values = {
        key: reader.number(fields[key].value, f"gait: {key}", low=low, high=high)
        for key, (low, high) in GAIT_BOUNDS.items()
        if key in fields
    }
    names = {"lift_sag": "lift_sag_mm"}
    return GaitCompensation(**{names.get(k, k): v for k, v in values.items() if v is not None})


def _servo_id(node: yaml.Node) -> int | None:
    try:
        return int(node.value) if isinstance(node, yaml.ScalarNode) else None
    except ValueError:
        return None


def _read_joint(reader: Reader, node: yaml.Node, what: str) -> dict[str, float]:
    values: dict[str, float] = {}
    for key, entry in (reader.fields(node, what, ACTUATOR_FIELDS) or {}).items():
        value = reader.number(
            entry.value,
            f"{what}: {key}",
            low=None if key in SIGNED_ACTUATOR_FIELDS else 0,
            high=MAX_RESPONSE_DELAY_S if key == "response_delay_s" else None,
            low_open=key not in ZERO_OK_ACTUATOR_FIELDS,
        )
        if value is not None and math.isfinite(value):
            values[key] = value
    return values
