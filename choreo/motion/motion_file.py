"""Motion files: ``motions/<robot>/*.yaml`` -> a validated, flattened ``Motion``.

Includes are expanded and mirrored here; every keyframe carries a full target vector (degrees,
in the robot's joint order) and where it was written, so later stages can point at the line.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import yaml

from choreo.core.arguments import check_flag, check_path, is_path, shown
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
    reading_a_file,
)
from choreo.errors import OptionError, SourceError, Worded
from choreo.motion.gait import BodyPose, Gait
from choreo.motion.keyframe_entry import (
    Include,
    Step,
    read_gait_block,
    read_keyframe,
    read_timing,
    t_where,
)
from choreo.motion.music_block import BeatRef, Music, past_song, read_music
from choreo.motion.scene import Prop, StartPosture, read_props, read_start
from choreo.motion.spatial import (
    GaitEnd,
    GaitSpec,
    SiteTarget,
    expand_spatial,
    has_key,
)
from choreo.motion.timing import (
    MAX_SPEED,
    MIN_SPEED,
    backward_times,
    known_arrivals_s,
    played_keyframes,
)
from choreo.robot.lookup import find_robot_file
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot, mirror_pose


@dataclass(frozen=True)
class Keyframe:
    targets_deg: tuple[float, ...]  # every joint, robot joint order (partial poses filled in)
    where: SourceLocation  # the keyframe's line in its file (the included file for includes)
    t_s: float | None = None  # absolute time from the motion start, before speed scaling
    after_s: float | None = None  # seconds after the previous keyframe (at most one of t/after)
    hold_s: float = 0.0  # stay this long once reached
    stop: bool = False  # come to rest here (implied by hold > 0, and at the ends)
    velocity_scale: float = 1.0  # MIN_VELOCITY_SCALE..1: fraction of the joint velocity limits
    label: str = ""  # pose name, or "" for an inline pose
    beat: BeatRef | None = None  # t_s was written as a beat or bar of the music
    sites: tuple[SiteTarget, ...] = ()  # written as sites: (solved into targets_deg by IK)
    body: BodyPose | None = None  # written as body: (feet planted, legs solved by IK)
    gait_end: GaitEnd | None = None  # the last keyframe of a gait: block


@dataclass(frozen=True)
class Motion:
    name: str
    path: Path
    robot: Robot
    keyframes: tuple[Keyframe, ...]
    description: str = ""
    speed: float = 1.0  # time scale: 2.0 plays twice as fast
    repeat: int = (
        1  # times to play; the planner wraps seamlessly from the last keyframe to the first
    )
    start: StartPosture = StartPosture.STANDING  # how the robot rests before it (preview)
    end: StartPosture = StartPosture.STANDING  # how it leaves the robot: lying is no fall
    props: tuple[Prop, ...] = ()  # boxes around the robot (preview)
    music: Music | None = None  # the song it dances to (keyframe times are already in seconds)


# --- reading motion files ----------------------------------------------------------------------

# repeat is unrolled: every played keyframe is planned, compiled and held in memory, so their
# number is bounded (a file can't ask for hours of planning and gigabytes of ticks). Measured:
# 4,000 played keyframes of the 18-servo hexapod take 5 s and 0.47 GB to plan.
MAX_PLAYED_KEYFRAMES = 10_000


def too_many_played(keyframes: int, repeat: int, what: str = "repeat") -> str | None:
    """The problem with playing ``keyframes`` keyframes ``repeat`` times, or ``None``."""
    if keyframes * repeat <= MAX_PLAYED_KEYFRAMES:
        return None
    if repeat == 1:
        return (
            f"{fmt(keyframes)} keyframes to play; at most {MAX_PLAYED_KEYFRAMES} are played in one "
            "motion: split it into shorter motions"
        )
    most = MAX_PLAYED_KEYFRAMES // keyframes
    return (
        f"{what} {fmt(repeat)} x {fmt(keyframes)} keyframe(s) = {fmt(keyframes * repeat)} "
        "keyframes to play; "
        f"at most {MAX_PLAYED_KEYFRAMES} are played in one motion: at most {most} "
        f"time{'s' if most != 1 else ''}"
    )


# The keys of each mapping, from the JSON Schema (the one description of the file's shape).
MOTION = mapping_shape("motion")
INCLUDE = mapping_shape("motion", "#/$defs/includeEntry")
HOME_POSE = "home"


def load_motion(path: str | os.PathLike[str], allow_past_song: bool = False) -> Motion:
    """Read a motion file and its robot; expand includes; fill partial poses.

    Every problem of the file, its includes and its robot is reported at once in one
    ``SourceError`` whose messages start ``path:line:col:``. A dance that would outlast its song
    is one of them unless ``allow_past_song``.
    """
    path = check_path("path", path, "a motion file's path")
    check_flag("allow_past_song", allow_past_song)
    problems = Problems()
    with reading_a_file():
        motion = _read_motion(Reader(path, problems), parse_yaml_file(path), allow_past_song)
    if motion is None or problems:
        raise SourceError(problems.messages)
    return motion


def motion_of(motion: object, allow_past_song: bool = False) -> Motion:
    """``motion`` itself, or the motion file it names, loaded (``OptionError`` for anything
    else): what the calls that take a motion accept."""
    if isinstance(motion, Motion):
        return motion
    if is_path(motion):
        return load_motion(motion, allow_past_song)
    raise OptionError(
        "motion",
        f"must be a Motion or a motion file's path (a str or os.PathLike), got {shown(motion)}",
    )


def _read_motion(reader: Reader, root: Node | None, allow_past_song: bool) -> Motion | None:
    fields = _motion_fields(reader, root)
    if fields is None:
        return None
    robot = _load_robot_of(reader, fields["robot"]) if "robot" in fields else None
    name = reader.string(fields["name"].value, "name") if "name" in fields else reader.path.stem
    description = (
        reader.string(fields["description"].value, "description") if "description" in fields else ""
    )
    speed = (
        reader.number(fields["speed"].value, "speed", low=MIN_SPEED, high=MAX_SPEED)
        if "speed" in fields
        else 1.0
    )
    repeat = reader.integer(fields["repeat"].value, "repeat", low=1) if "repeat" in fields else 1
    start = (
        read_start(reader, fields["start"].value) if "start" in fields else StartPosture.STANDING
    )
    end = (
        read_start(reader, fields["end"].value, "end") if "end" in fields else StartPosture.STANDING
    )
    props = read_props(reader, fields["props"].value) if "props" in fields else ()
    music = read_music(reader, fields["music"]) if "music" in fields else None
    if music is not None and speed not in (None, 1.0):
        reader.report(
            fields["speed"].value,
            f"speed {fmt(speed)} would leave the music behind (the song plays at its own "
            "tempo); remove speed, or the music block",
        )
    if robot is None or "keyframes" not in fields:
        return None
    chain = (Include(reader.path, None, music, "music" in fields and music is None),)
    steps = _read_steps(reader, fields["keyframes"], robot, chain)
    if (
        name is None
        or description is None
        or speed is None
        or repeat is None
        or start is None
        or end is None
        or props is None
        or reader.problems
    ):
        return None
    # counted before the gaits are solved: a long walk is refused before the work, not after
    if _too_many_keyframes(reader, fields, steps, repeat):
        return None
    steps = expand_spatial(robot, steps, reader.problems)  # IK: joint keyframes from here on
    if reader.problems:
        return None
    keyframes = _fill_poses(robot, steps)
    outlasts = None if allow_past_song else past_song(music, keyframes, repeat)
    if outlasts is not None:
        reader.report(
            fields["repeat" if "repeat" in fields else "keyframes"].key_node,
            Worded(
                f"{outlasts}; end it sooner, start earlier in the song, or pass "
                "{allow_past_song} to dance on in silence",
                ("allow_past_song",),
            ),
        )
        return None
    return Motion(
        name=name,
        path=reader.path,
        robot=robot,
        keyframes=keyframes,
        description=description,
        speed=speed,
        repeat=repeat,
        start=start,
        end=end,
        props=props,
        music=music,
    )


def _motion_fields(reader: Reader, root: Node | None) -> dict[str, Entry] | None:
    if root is None:
        reader.problems.add(
            SourceLocation(reader.path, 1, 1),
            "the file is empty; a motion needs robot and keyframes",
        )
        return None
    return reader.fields(root, "the motion file", MOTION.keys, required=MOTION.required)


def _load_robot_of(reader: Reader, entry: Entry) -> Robot | None:
    robot_path = _find_robot_of(reader, entry)
    if robot_path is None:
        return None
    try:
        return load_robot(robot_path)
    except SourceError as error:
        reader.report(
            entry.value, f"robot {robot_path} has problems (listed after this line); fix them first"
        )
        reader.problems.extend(error.problems)
        return None


def _find_robot_of(reader: Reader, entry: Entry) -> Path | None:
    ref = reader.string(entry.value, "robot")
    if ref is None:
        return None
    try:
        return find_robot_file(ref, relative_to=reader.path)
    except LookupError as error:
        reader.report(entry.value, str(error))
        return None


def _read_steps(
    reader: Reader, entry: Entry, robot: Robot, chain: tuple[Include, ...]
) -> list[Step]:
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


def most_gait_steps(gait: Gait, other_keyframes: int) -> int:
    """The most steps of ``gait`` (its pattern) a motion with ``other_keyframes`` keyframes
    besides the gait's plays once: every keyframe of the gait counts."""
    per_step = gait.keyframes_per_step
    after_the_steps = gait.keyframes - gait.steps * per_step  # swings running past the last
    return (MAX_PLAYED_KEYFRAMES - other_keyframes - after_the_steps) // per_step


def _too_many_keyframes(
    reader: Reader, fields: dict[str, Entry], steps: list[Step], repeat: int
) -> bool:
    """Whether the motion plays more keyframes than it may, reported: at a gait's steps where
    fewer of them would do (the longest gait's), else at repeat or keyframes."""
    gaits = [step.space for step in steps if isinstance(step.space, GaitSpec)]
    total = sum(spec.gait.keyframes for spec in gaits) + len(steps) - len(gaits)
    problem = too_many_played(total, repeat)
    if problem is None:
        return False
    longest = max(gaits, key=lambda spec: spec.gait.keyframes, default=None)
    if repeat == 1 and longest is not None:
        gait = longest.gait
        others = total - gait.keyframes
        most = most_gait_steps(gait, others)
        if most >= 1:
            plural = "s" if others != 1 else ""
            besides = f", with the motion's {fmt(others)} other keyframe{plural}" if others else ""
            reader.problems.add(
                longest.steps_at,
                f"gait: steps {fmt(gait.steps)} of the {gait.pattern.value} gait are "
                f"{fmt(gait.keyframes)} keyframes ({gait.keyframes_per_step} a step){besides}; "
                f"at most {MAX_PLAYED_KEYFRAMES} are played in one motion: steps at most {most}",
            )
            return True
    where = fields["repeat"].value if "repeat" in fields else fields["keyframes"].key_node
    reader.report(where, problem)
    return True


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
        fields = _motion_fields(reader, parse_yaml_file(link.path))
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
    robot_path = _find_robot_of(reader, fields["robot"]) if "robot" in fields else None
    if robot_path is not None and robot_path.resolve() != robot.path.resolve():
        reader.report(
            fields["robot"].value,
            f"an included file must use the including motion's robot "
            f"{robot.name!r} ({robot.path}), not {robot_path} (included at {link.entry})",
        )
        return []
    if robot_path is None or "keyframes" not in fields:
        return []
    return _read_steps(reader, fields["keyframes"], robot, chain)


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


def _fill_poses(robot: Robot, steps: list[Step]) -> tuple[Keyframe, ...]:
    """Full target vectors: a joint not named keeps its previous target (home at first)."""
    current = dict(robot.poses[HOME_POSE])
    keyframes = []
    for step in steps:
        current.update(step.angles_deg)
        keyframes.append(
            Keyframe(
                targets_deg=tuple(current[name] for name in robot.joint_names),
                where=step.where,
                t_s=step.t_s,
                after_s=step.after_s,
                hold_s=step.hold_s,
                stop=step.stop,
                velocity_scale=step.velocity_scale,
                label=step.label,
                beat=step.beat,
                sites=step.sites,
                body=step.body,
                gait_end=step.gait_end,
            )
        )
    return tuple(keyframes)
