"""What a motion says about its surroundings: how the robot lies or stands when it starts
(``start:``) and the simple props around it (``props:``), read from the motion file.

Only the preview uses them (the player starts wherever the robot is); they live here, without
MuJoCo, so that reading a motion file never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from choreo.core.yaml_source import Node, Reader, SourceLocation


class StartPosture(str, Enum):
    """How a free-floating robot rests on the floor before the motion.

    STANDING: upright on its feet (the MJCF's ``home`` orientation). LYING: that orientation but
    resting on whatever is lowest (a hexapod on its belly). LYING_FRONT / LYING_BACK: turned
    90° about its side-to-side axis, face down / face up (a humanoid on the floor).
    """

    STANDING = "standing"
    LYING = "lying"
    LYING_FRONT = "lying_front"
    LYING_BACK = "lying_back"

    @property
    def lying(self) -> bool:
        return self is not StartPosture.STANDING

    @property
    def pitch_deg(self) -> float:
        """The turn about the world y axis from the ``home`` orientation (x = forward)."""
        return {StartPosture.LYING_FRONT: 90.0, StartPosture.LYING_BACK: -90.0}.get(self, 0.0)


PROP_KEYS = ("name", "size_m", "at_m", "yaw_deg", "mass_kg", "friction", "place_at_m")
# A prop's numbers, as reader.number's bounds: a room around a desktop or walking robot, far from
# the numbers (1.0e+308) that blow up the simulation (and MuJoCo prints a warning a step).
PROP_BOUNDS: dict[str, dict[str, Any]] = {
    "size_m": {"low": 0, "high": 10, "low_open": True, "unit": " m"},
    "at_m": {"low": -10, "high": 10, "unit": " m"},
    "place_at_m": {"low": -10, "high": 10, "unit": " m"},
    "yaw_deg": {"low": -180, "high": 180, "unit": "°"},
    "mass_kg": {"low": 0, "high": 1000, "low_open": True, "unit": " kg"},
    "friction": {"low": 0, "high": 10, "low_open": True},
}


@dataclass(frozen=True)
class Prop:
    """A box standing in the world: ``at_m`` is the centre of its bottom face (z = 0 on the
    floor), ``size_m`` its full length, width and height, ``yaw_deg`` its turn about z.

    Without ``mass_kg`` it is fixed scenery; with it, a free body that falls, can be pushed,
    gripped and carried (``friction``: its sliding friction coefficient, MuJoCo's 1 by default).
    ``place_at_m``: where the motion is meant to leave a free prop (its bottom face's centre),
    which the preview checks."""

    name: str
    size_m: tuple[float, float, float]
    at_m: tuple[float, float, float]
    yaw_deg: float = 0.0
    mass_kg: float | None = None
    friction: float | None = None
    place_at_m: tuple[float, float, float] | None = None
    where: SourceLocation | None = field(default=None, compare=False)  # its name, for messages

    @property
    def free(self) -> bool:
        return self.mass_kg is not None


def read_start(reader: Reader, node: Node, key: str = "start") -> StartPosture | None:
    """``start:`` (or ``end:``): a posture name."""
    value = reader.choice(node, key, [p.value for p in StartPosture])
    return None if value is None else StartPosture(value)


def read_props(reader: Reader, node: Node) -> tuple[Prop, ...] | None:
    """``props:`` a list of boxes; every problem reported, None if any."""
    items = reader.sequence(node, "props")
    if items is None:
        return None
    props, names, ok = [], set(), True
    for index, item in enumerate(items):
        prop = _read_prop(reader, item, f"props[{index}]")
        if prop is not None and prop.name in names:
            reader.report(item, f"props[{index}]: the name {prop.name!r} is used twice")
            prop = None
        if prop is None:
            ok = False
            continue
        names.add(prop.name)
        props.append(prop)
    return tuple(props) if ok else None


def _read_prop(reader: Reader, node: Node, what: str) -> Prop | None:
    fields = reader.fields(node, what, PROP_KEYS, required=("name", "size_m", "at_m"))
    if fields is None or not {"name", "size_m", "at_m"} <= set(fields):
        return None
    name = reader.string(fields["name"].value, f"{what}: name")
    size = _vector(reader, fields["size_m"].value, f"{what}: size_m", PROP_BOUNDS["size_m"])
    at = _vector(reader, fields["at_m"].value, f"{what}: at_m", PROP_BOUNDS["at_m"])
    yaw = (
        reader.number(fields["yaw_deg"].value, f"{what}: yaw_deg", **PROP_BOUNDS["yaw_deg"])
        if "yaw_deg" in fields
        else 0.0
    )
    if name is None or size is None or at is None or yaw is None:
        return None
    free = _read_free(reader, fields, what)
    if free is None:
        return None
    return Prop(name, size, at, yaw, *free, where=reader.where(fields["name"].value))


def _read_free(
    reader: Reader, fields: dict, what: str
) -> tuple[float | None, float | None, tuple[float, float, float] | None] | None:
    """A free prop's ``mass_kg``, ``friction`` and ``place_at_m`` (all None for a fixed prop),
    or None when one is wrong (reported)."""
    values: dict[str, object] = {}
    for key in ("mass_kg", "friction", "place_at_m"):
        if key not in fields:
            values[key] = None
            continue
        node = fields[key].value
        if key != "mass_kg" and "mass_kg" not in fields:
            reader.report(node, f"{what}: {key} needs mass_kg (a prop without it stays fixed)")
            return None
        if key == "place_at_m":
            values[key] = _vector(reader, node, f"{what}: {key}", PROP_BOUNDS[key])
        else:
            values[key] = reader.number(node, f"{what}: {key}", **PROP_BOUNDS[key])
        if values[key] is None:
            return None
    return values["mass_kg"], values["friction"], values["place_at_m"]  # type: ignore[return-value]


def _vector(
    reader: Reader, node: Node, what: str, bounds: dict[str, Any]
) -> tuple[float, float, float] | None:
    items = reader.sequence(node, what)
    if items is None:
        return None
    if len(items) != 3:
        reader.report(node, f"{what} needs three numbers [x, y, z] in metres, got {len(items)}")
        return None
    values = [reader.number(item, what, **bounds) for item in items]
    x, y, z = values
    if x is None or y is None or z is None:
        return None
    return (x, y, z)
