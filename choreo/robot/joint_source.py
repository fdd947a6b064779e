"""A joint as robot.yaml writes it, kept beside the joint read from it, so that checks made after
reading (the MuJoCo model's, in ``model_check``) can point at the line that wrote it."""

from __future__ import annotations

from dataclasses import dataclass

from choreo.core.yaml_source import Entry, Node
from choreo.robot.types import Joint


@dataclass(frozen=True)
class JointSource:
    """A joint as written: its name's node, its entries (defaults merged in) and the result."""

    name: str
    key_node: Node
    fields: dict[str, Entry]
    joint: Joint | None  # None when one of its values was refused
