"""Keyframes -> motion file text (``motions/<robot>/*.yaml``); callers write it with
:func:`choreo.core.atomic.write_text_atomically`.

The text is meant for people as much as for the loader: a keyframe that equals one of the
robot's poses is written by its name, any other names only the joints that differ from the
keyframe before (partial poses; the first keyframe against ``home``), numbers are written in
their shortest exact form, so loading the file gives back the same keyframes bit for bit.
"""

from __future__ import annotations

import json
import os
import re
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from choreo.motion.motion_file import HOME_POSE, Keyframe
from choreo.motion.scene import Prop, StartPosture
from choreo.robot.lookup import find_robot_file
from choreo.robot.types import Robot

LINE_WIDTH = 100
_PLAIN_TEXT = re.compile(r"[A-Za-z0-9][\w .,()/+-]*")  # needs no quotes in YAML


def motion_text(
    robot: Robot,
    keyframes: Sequence[Keyframe],
    *,
    robot_ref: str,
    description: str = "",
    speed: float = 1.0,
    repeat: int = 1,
    header: Sequence[str] = (),
    comments: Mapping[int, str] | None = None,
    music: str = "",
    name: str = "",
    start: StartPosture = StartPosture.STANDING,
    end: StartPosture = StartPosture.STANDING,
    props: Sequence[Prop] = (),
) -> str:
    """The YAML text of a motion of ``robot`` (named by ``robot_ref``) with these keyframes.

    ``header``: comment lines for the top of the file; ``comments``: keyframe index -> a comment
    for that keyframe, at the end of its last line if it is one short line, else on the lines
    before it; ``music``: the music block as one flow mapping
    (``choreo.motion.music_block.music_text``); ``name``: "" leaves it to default to the file
    name; ``start``, ``end`` and ``props``: what the preview reads (written when not the
    default).
    """
    lines = [f"# {line}".rstrip() for line in header]
    if name:
        lines.append(f"name: {_text(name)}")
    if description:
        lines += _description_lines(description)
    lines.append(f"robot: {_text(robot_ref)}")
    for key, posture in (("start", start), ("end", end)):
        if posture is not StartPosture.STANDING:
            lines.append(f"{key}: {posture.value}")
    if props:
        lines += ["props:", *(_prop_line(prop) for prop in props)]
    if speed != 1.0:
        lines.append(f"speed: {_number(speed)}")
    if repeat != 1:
        lines.append(f"repeat: {repeat}")
    if music:
        lines.append(f"music: {music}")
    lines.append("keyframes:")
    previous = robot.pose_vector(HOME_POSE)
    for index, keyframe in enumerate(keyframes):
        keyframe_lines = _keyframe_lines(robot, keyframe, previous)
        comment = (comments or {}).get(index, "")
        if (
            comment
            and "\n" not in comment
            and len(keyframe_lines[-1]) + len(comment) + 4 <= LINE_WIDTH
        ):
            keyframe_lines[-1] += f"  # {comment}"
        else:
            lines += [f"  # {line}".rstrip() for line in comment.splitlines()]
        lines += keyframe_lines
        previous = keyframe.targets_deg
    return "\n".join(lines) + "\n"


def robot_reference(robot: Robot, motion_path: Path) -> str:
    """How a motion file at ``motion_path`` names ``robot``: its name if that finds this very
    robot from there, else the path of its robot.yaml relative to the motion's folder (absolute
    across Windows drives)."""
    try:
        if find_robot_file(robot.name, relative_to=motion_path).resolve() == robot.path.resolve():
            return robot.name
    except LookupError:
        pass
    try:
        relative = os.path.relpath(robot.path.resolve(), motion_path.resolve().parent)
    except ValueError:
        return robot.path.resolve().as_posix()
    return Path(relative).as_posix()


# --- one keyframe ------------------------------------------------------------------------------


def _keyframe_lines(robot: Robot, keyframe: Keyframe, previous: Sequence[float]) -> list[str]:
    lines = [f"  - pose: {_pose_text(robot, keyframe, previous, indent=len('  - pose: '))}"]
    if keyframe.t_s is not None:
        lines.append(f"    t: {_number(keyframe.t_s)}")
    if keyframe.after_s is not None:
        lines.append(f"    after: {_number(keyframe.after_s)}")
    if keyframe.hold_s:
        lines.append(f"    hold: {_number(keyframe.hold_s)}")
    elif keyframe.stop:  # a hold implies the stop
        lines.append("    stop: true")
    if keyframe.velocity_scale != 1.0:
        lines.append(f"    velocity: {_number(keyframe.velocity_scale)}")
    return lines


def _pose_text(robot: Robot, keyframe: Keyframe, previous: Sequence[float], indent: int) -> str:
    targets = tuple(keyframe.targets_deg)
    named = [keyframe.label] if keyframe.label else []
    for name in (*named, *robot.poses):
        if name in robot.poses and robot.pose_vector(name) == targets:
            return name
    changed = [
        f"{joint}: {_number(angle)}"
        for joint, angle, before in zip(robot.joint_names, targets, previous)
        if angle != before
    ]
    return _flow_mapping(changed, indent)


def _prop_line(prop: Prop) -> str:
    """One prop as a flow mapping in a list, its fields in the file's order."""
    items = [
        f"name: {_text(prop.name)}",
        f"size_m: {_vector(prop.size_m)}",
        f"at_m: {_vector(prop.at_m)}",
    ]
    if prop.yaw_deg:
        items.append(f"yaw_deg: {_number(prop.yaw_deg)}")
    for key, value in (("mass_kg", prop.mass_kg), ("friction", prop.friction)):
        if value is not None:
            items.append(f"{key}: {_number(value)}")
    if prop.place_at_m is not None:
        items.append(f"place_at_m: {_vector(prop.place_at_m)}")
    return "  - " + _flow_mapping(items, indent=len("  - "))


def _vector(values: Sequence[float]) -> str:
    return "[" + ", ".join(_number(v) for v in values) + "]"


def _flow_mapping(items: list[str], indent: int) -> str:
    """``{a: 1, b: 2}``, wrapped before ``LINE_WIDTH`` with continuation lines under the ``{``."""
    lines = [""]
    for k, item in enumerate(items):
        piece = item + ("," if k < len(items) - 1 else "")
        if lines[-1] and indent + 1 + len(lines[-1]) + 1 + len(piece) + 1 > LINE_WIDTH:
            lines.append("")
        lines[-1] += (" " if lines[-1] else "") + piece
    return "{" + f"\n{' ' * (indent + 1)}".join(lines) + "}"


def _number(value: float) -> str:
    """The shortest text that reads back as exactly ``value``: ``18``, ``26.4``, ``0.00001``
    (positional: YAML 1.1 reads ``1e-05`` as a string)."""
    value = float(value) + 0.0  # no -0.0
    return np.format_float_positional(value, unique=True, trim="-")


def _description_lines(text: str) -> list[str]:
    """``description: ...`` on one line, or folded (``>-``) over several when it is long."""
    line = f"description: {_text(text)}"
    if len(line) <= LINE_WIDTH:
        return [line]
    wrapped = textwrap.wrap(text, LINE_WIDTH - 2, break_long_words=False, break_on_hyphens=False)
    folded = ["description: >-", *(f"  {part}" for part in wrapped)]
    if yaml.safe_load("\n".join(folded)) == {"description": text}:
        return folded
    return [line]  # wrapping would change it (runs of spaces, line breaks): keep it quoted


def _text(value: str) -> str:
    """A YAML scalar for ``value``: plain where that reads back unchanged, else double-quoted
    (JSON strings are YAML double-quoted scalars)."""
    if _PLAIN_TEXT.fullmatch(value) and not value.endswith(" ") and yaml.safe_load(value) == value:
        return value
    return json.dumps(value, ensure_ascii=False)
