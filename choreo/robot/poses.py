"""A robot's named poses as robot.yaml writes them, and a ``joint: degrees`` mapping read and
checked against the joints' limits (also for a motion's keyframes)."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import yaml

from choreo.core.yaml_source import STR_TAG, Entry, Node, Reader, did_you_mean, fmt, plain_number
from choreo.robot.joint_entry import all_given
from choreo.robot.types import Joint

HOME_POSE = "home"  # the pose every robot has: motions start from it and fill partial poses


def read_angles(
    reader: Reader, node: Node, what: str, joints: Mapping[str, Joint | None]
) -> dict[str, float | None] | None:
    """A ``joint: degrees`` mapping: each joint known and each angle inside its limits.

    A named joint whose angle was refused (reported) maps to ``None``; a joint that is itself
    ``None`` (refused while reading the robot) is not limit-checked.
    """
    plain = _plain_angles(node, joints)
    if plain is not None:
        return plain
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


def _plain_angles(node: Node, joints: Mapping[str, Joint | None]) -> dict[str, float | None] | None:
    """What ``read_angles`` reads from a mapping with nothing to report: each key a joint's
    name, given once, each angle a plain number inside the joint's limits. ``None`` for
    anything else, which ``read_angles`` reads in full, and reports. A motion's poses are
    nearly all such mappings, of some 25,000 angles in a long motion: checked in one loop,
    they are read in a third of the time."""
    if not isinstance(node, yaml.MappingNode):
        return None
    angles: dict[str, float | None] = {}
    for key_node, value_node in node.value:
        name = key_node.value
        plain_key = key_node.tag == STR_TAG and isinstance(key_node, yaml.ScalarNode)
        joint = joints.get(name) if plain_key else None
        angle = plain_number(value_node)
        if (
            joint is None
            or angle is None
            or name in angles
            or not joint.limits.min_deg <= angle <= joint.limits.max_deg
        ):
            return None
        angles[name] = angle
    return angles


def read_poses(
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
        elif (given := all_given(angles)) is not None:
            poses[pose.key] = MappingProxyType({name: given[name] for name in joints})
    names = [pose.key for pose in pose_entries or []]
    if pose_entries is not None and HOME_POSE not in names:
        reader.report(
            entry.key_node,
            f"poses: the 'home' pose is missing"
            f"{did_you_mean('home', names)}; it is required: motions "
            f"start from it and fill partial first poses from it",
        )
    return poses
