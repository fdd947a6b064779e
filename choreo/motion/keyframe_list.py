"""The ``keyframes:`` list of a motion file read into steps: keyframes, gait blocks and includes
of other motion files (read as the including file's robot and music, their t values made a block,
mirrored on request), with the times checked to increase along them. Included files are motion
files too: their keys are read here (``motion_fields``)."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import yaml

from choreo.core.file_kind import not_a_file
from choreo.core.file_shape import mapping_shape
from choreo.core.yaml_source import (
    Entry,
    Node,
    Problems,
    Reader,
    SourceLocation,
    fmt,
    parse_yaml_file,
)
from choreo.errors import SourceError
from choreo.motion.keyframe_entry import (
    Include,
    Step,
    read_gait_block,
    read_keyframe,
    read_timing,
    t_where,
)
from choreo.motion.music_block import BeatRef
from choreo.motion.spatial import (
    has_key,
)
from choreo.motion.timing import (
    backward_times,
    known_arrivals_s,
    played_keyframes,
)
from choreo.robot.lookup import find_robot_file
from choreo.robot.types import Robot, mirror_pose

# The keys of each mapping, from the JSON Schema (the one description of the file's shape).
MOTION = mapping_shape("motion")
INCLUDE = mapping_shape("motion", "#/$defs/includeEntry")


def motion_fields(reader: Reader, root: Node | None) -> dict[str, Entry] | None:
    """The keys of a motion file (the including one or one it includes), checked."""
    if root is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            "the file is empty; a motion needs robot and keyframes",
        )
        return None
    return reader.fields(root, "the motion file", MOTION.keys, required=MOTION.required)


def find_robot_of(reader: Reader, entry: Entry) -> Path | None:
    """The robot file the ``robot:`` entry names, or None (reported)."""
    ref = reader.string(entry.value, "robot")
    if ref is None:
        return None
    try:
        return find_robot_file(ref, relative_to=reader.path)
    except LookupError as error:
        reader.report(entry.value, str(error))
        return None


def read_steps(
    reader: Reader, entry: Entry, robot: Robot, chain: tuple[Include, ...]
) -> list[Step]:
    """The steps the ``keyframes:`` entry lists, includes expanded; ``chain``: the files
    including this one, this one first."""
    items = reader.sequence(entry.value, "keyframes")
    if items is None:
        return []
    if not items:
        reader.report(entry.key_node, "keyframes: the motion has no keyframes; give at least one")
    steps: list[Step] = []
    for item in items:
        if isinstance(item, yaml.MappingNode) and any(k.value == "include" for k, _ in item.value):
            steps.extend(_read_include(reader, item, robot, chain))
        elif has_key(item, "gait"):
            steps += read_gait_block(reader, item)
        else:
            step = read_keyframe(reader, item, robot, chain[0])
            if step is not None and len(chain) > 1:  # say through which includes it came
                entries = tuple(link.entry for link in reversed(chain[1:]) if link.entry)
                step = replace(step, where=replace(step.where, included_at=entries))
            steps += [step] if step is not None else []
    _check_times(reader, steps)
    return steps


def _check_times(reader: Reader, steps: list[Step]) -> None:
    """t values increase along the file, counting the holds and after delays in between."""
    for backward in backward_times(played_keyframes(steps)):
        step = steps[backward.index]
        reader.problems.add(
            step.t_where or step.where,  # a step with a t knows where it was written
            f"{_time_text(backward.t_s, step.beat)} goes backwards: the keyframe "
            f"before it ({steps[backward.index - 1].where}) cannot be "
            f"left before {fmt(backward.earliest_leave_s)} s; t values must "
            f"increase along the file",
        )


def _time_text(t_s: float, beat: BeatRef | None) -> str:
    """'t 2.5', or for a keyframe written on a beat 'beat 6 (t 2.500)'."""
    if beat is None:
        return f"t {fmt(t_s)}"
    return f"{beat.describe(beat.grid.beat_at(t_s))} (t {t_s:.3f})"


def _read_include(
    reader: Reader, item: Node, robot: Robot, chain: tuple[Include, ...]
) -> list[Step]:
    what = "an include entry (pose, hold, stop and velocity go in the included keyframes)"
    fields = reader.fields(item, what, INCLUDE.keys, required=INCLUDE.required)
    if fields is None:
        return []
    relative = reader.string(fields["include"].value, "include")
    mirror = reader.boolean(fields["mirror"].value, "mirror") if "mirror" in fields else False
    timing = read_timing(reader, fields, chain[0])
    if relative is None or mirror is None or timing is None:
        return []
    path = reader.path.parent / relative
    link = Include(path, reader.where(fields["include"].value), chain[0].music)
    if any(_same_file(path, earlier.path) for earlier in chain):
        files = " -> ".join(str(earlier.path) for earlier in (*chain, link))
        reader.report(
            fields["include"].value,
            f"include cycle: {files}; a motion cannot include itself, directly or through others",
        )
        return []
    kind = not_a_file(path)
    if kind is not None or not path.is_file():
        reader.report(
            fields["include"].value,
            f"include: {path} is {kind}, not a motion file"
            if kind is not None
            else f"include: {path} does not exist (paths are relative to this file's folder)",
        )
        return []
    steps = _block(
        reader,
        _read_included(reader.problems, robot, (*chain, link)),
        timing,
        t_where(reader, fields),
    )
    if mirror:
        steps = _mirror_block(reader, fields["mirror"].value, robot, steps)
    return steps


def _same_file(a: Path, b: Path) -> bool:
    # realpath, not Path.resolve: a loop of symbolic links is reported, not a RuntimeError
    return os.path.realpath(a) == os.path.realpath(b)


def _read_included(problems: Problems, robot: Robot, chain: tuple[Include, ...]) -> list[Step]:
    """The steps of an included file, whose robot must be ``robot``; no speed, repeat, start or
    props."""
    link = chain[-1]
    reader = Reader(link.path, problems)
    try:
        fields = motion_fields(reader, parse_yaml_file(link.path))
    except SourceError as error:
        problems.extend(error.problems)
        return []
    if fields is None:
        return []
    for key in ("name", "description"):
        if key in fields:
            reader.string(fields[key].value, key)
    for key in ("speed", "repeat", "start", "end", "props"):
        if key in fields:
            reader.report(
                fields[key].key_node,
                f"{key} is not allowed in an included file "
                f"(included at {link.entry}): the including "
                f"motion's {key} applies; remove it",
            )
    robot_path = find_robot_of(reader, fields["robot"]) if "robot" in fields else None
    if robot_path is not None and robot_path.resolve() != robot.path.resolve():
        reader.report(
            fields["robot"].value,
            f"an included file must use the including motion's robot "
            f"{robot.name!r} ({robot.path}), not {robot_path} (included at {link.entry})",
        )
        return []
    if robot_path is None or "keyframes" not in fields:
        return []
    return read_steps(reader, fields["keyframes"], robot, chain)


def _block(
    reader: Reader,
    steps: list[Step],
    timing: tuple[float | None, float | None, BeatRef | None],
    t_where: SourceLocation | None,
) -> list[Step]:
    """Included steps as a block: its t values become after delays (keeping their spacing), and
    the include entry's timing, if any, replaces the first step's (``t_where``: its t's place).

    The included file's time starts when the keyframe before the include is left; an untimed
    first step is the origin of its t values.
    """
    if not steps:
        return []
    arrivals_s = known_arrivals_s(played_keyframes(steps))  # in the included file's time
    first = steps[0]
    own = first.t_s if first.t_s is not None else first.after_s
    t_s, after_s, beat = timing if timing[:2] != (None, None) else (None, own, None)
    block = [replace(first, t_s=t_s, after_s=after_s, t_where=t_where, beat=beat)]
    for index, step in enumerate(steps[1:], start=1):
        previous, previous_arrival_s = steps[index - 1], arrivals_s[index - 1]
        if step.t_s is None:
            block.append(step)
        elif previous_arrival_s is None:
            reader.problems.add(
                step.t_where or step.where,  # a step with a t knows where it was written
                "t in an included file becomes an after delay, so "
                f"the keyframe before it ({previous.where}) needs a "
                "t or after too; give it one, or use after here",
            )
        else:
            after_s = step.t_s - previous_arrival_s - previous.hold_s
            block.append(replace(step, t_s=None, after_s=after_s, t_where=None, beat=None))
    return block


def _mirror_block(reader: Reader, mirror_node: Node, robot: Robot, steps: list[Step]) -> list[Step]:
    """Steps mirrored with the robot's mirror pairs; mirrored angles must be inside the limits."""
    if not robot.mirror_pairs:
        reader.report(
            mirror_node, f"robot {robot.name!r} has no mirror pairs; add 'mirror:' to {robot.path}"
        )
        return steps
    mirrored: list[Step] = []
    for step in steps:
        if step.space is not None:
            reader.report(
                mirror_node,
                f"mirror: the keyframe at {step.where} is given in space (sites, body or "
                f"gait), which cannot be mirrored; mirror a file of joint keyframes",
            )
        angles = mirror_pose(robot, step.angles_deg)
        for outside in robot.limit_violations(angles):
            reader.report(
                mirror_node,
                f"mirror: the keyframe at {step.where} mirrored puts {outside.joint.name} at "
                f"{fmt(outside.angle_deg)}°, outside its limits {outside.joint.limits.range_text}",
            )
        mirrored.append(replace(step, angles_deg=angles, label=""))
    return mirrored
