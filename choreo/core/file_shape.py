"""The shape of choreo's files, read from the JSON Schemas shipped for editors (``choreo/schema``):
which keys each mapping allows and requires, and the values a key takes from a fixed list.

The schemas are the one description of that shape: the loaders (``robot_file``, ``motion``) take
their keys from here, so an editor and ``choreo validate`` can never disagree about a key. What
needs the robot or other files (joint names, limits, timing, includes) stays in the loaders.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Shape:
    """A mapping's keys: every key allowed (in the schema's order) and those required."""

    keys: tuple[str, ...]
    required: tuple[str, ...]


# Beside the package's modules, as pyproject ships them. Read by path: importlib.resources
# brings zipfile and tempfile into every command's start (with the lazy imports of tempfile,
# difflib and decimal, some 30 million instructions of a `choreo plan`) for a package that is
# never run from a zip.
SCHEMA_FOLDER = Path(__file__).resolve().parents[1] / "schema"


@cache
def _schema(name: str) -> dict[str, Any]:
    text = (SCHEMA_FOLDER / f"{name}.schema.json").read_text(encoding="utf-8")
    return json.loads(text)


def _at(schema: dict[str, Any], pointer: str) -> dict[str, Any]:
    """The part of ``schema`` at a JSON pointer such as ``#/$defs/keyframe`` ('' is the root)."""
    node = schema
    for part in pointer.removeprefix("#").split("/"):
        if part:
            node = node[part]
    return node


@cache
def mapping_shape(schema_name: str, pointer: str = "") -> Shape:
    """The keys of the object at ``pointer`` in ``<schema_name>.schema.json``: its own
    properties, then those of the definition it refers to (``$ref``), recursively."""
    schema = _schema(schema_name)
    keys: dict[str, None] = {}  # ordered set
    required: dict[str, None] = {}
    node: dict[str, Any] | None = _at(schema, pointer)
    while node is not None:
        keys.update(dict.fromkeys(node.get("properties", {})))
        required.update(dict.fromkeys(node.get("required", ())))
        node = _at(schema, node["$ref"]) if "$ref" in node else None
    if not keys:
        raise ValueError(f"{schema_name}.schema.json{pointer} describes no mapping with keys")
    return Shape(tuple(keys), tuple(required))


def choices(schema_name: str, pointer: str) -> tuple[Any, ...]:
    """The values allowed at ``pointer`` (its ``enum``)."""
    return tuple(_at(_schema(schema_name), pointer)["enum"])
