"""Motion files: ``motions/<robot>/*.yaml`` -> a validated, flattened ``Motion``.

Includes are expanded and mirrored here; every keyframe carries a full target vector (degrees,
in the robot's joint order) and where it was written, so later stages can point at the line.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from choreo.core.arguments import check_flag, check_path, is_path, shown
from choreo.core.collector import collector_paused
from choreo.core.yaml_source import (
    Entry,
    Node,
    Problems,
    Reader,
    SourceLocation,
    fmt,
    parse_yaml_file,
)
from choreo.errors import OptionError, SourceError, Worded
from choreo.motion.gait import BodyPose, Gait
from choreo.motion.keyframe_entry import (
    Include,
    Step,
)
from choreo.motion.keyframe_list import find_robot_of, motion_fields, read_steps
from choreo.motion.music_block import BeatRef, Music, past_song, read_music
from choreo.motion.scene import Prop, StartPosture, read_props, read_start
from choreo.motion.spatial import (
    GaitEnd,
    GaitSpec,
    SiteTarget,
    expand_spatial,
)
from choreo.motion.timing import (
    MAX_SPEED,
    MIN_SPEED,
)
from choreo.robot.poses import HOME_POSE
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot


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


def load_motion(path: str | os.PathLike[str], allow_past_song: bool = False) -> Motion:
    """Read a motion file and its robot; expand includes; fill partial poses.

    Every problem of the file, its includes and its robot is reported at once in one
    ``SourceError`` whose messages start ``path:line:col:``. A dance that would outlast its song
    is one of them unless ``allow_past_song``.
    """
    path = check_path("path", path, "a motion file's path")
    check_flag("allow_past_song", allow_past_song)
    with collector_paused():
        return motion_of_yaml(path, parse_yaml_file(path), allow_past_song)


def motion_of_yaml(path: Path, root: Node | None, allow_past_song: bool = False) -> Motion:
    """The motion in ``path``, its YAML already parsed into ``root`` (as by ``parse_yaml_file``),
    for a caller that looked at the tree first; otherwise as ``load_motion``."""
    problems = Problems()
    with collector_paused():
        motion = _read_motion(Reader(path, problems), root, allow_past_song)
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
    """The motion the file describes, or None when any of it was refused (reported)."""
    fields = motion_fields(reader, root)
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
    music = _read_music(reader, fields, speed)
    if robot is None or "keyframes" not in fields:
        return None
    chain = (Include(reader.path, None, music, "music" in fields and music is None),)
    steps = read_steps(reader, fields["keyframes"], robot, chain)
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
    keyframes = _keyframes(reader, fields, robot, steps, repeat, music, allow_past_song)
    if keyframes is None:
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


def _read_music(reader: Reader, fields: dict[str, Entry], speed: float | None) -> Music | None:
    """The song the motion dances to, which plays at its own tempo: no speed beside it."""
    music = read_music(reader, fields["music"]) if "music" in fields else None
    if music is not None and speed not in (None, 1.0):
        reader.report(
            fields["speed"].value,
            f"speed {fmt(speed)} would leave the music behind (the song plays at its own "
            "tempo); remove speed, or the music block",
        )
    return music


def _keyframes(
    reader: Reader,
    fields: dict[str, Entry],
    robot: Robot,
    steps: list[Step],
    repeat: int,
    music: Music | None,
    allow_past_song: bool,
) -> tuple[Keyframe, ...] | None:
    """The motion's keyframes from its steps: counted, solved by IK, their partial poses filled
    and held against the song; None when that is refused (reported)."""
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
    return keyframes


def _load_robot_of(reader: Reader, entry: Entry) -> Robot | None:
    robot_path = find_robot_of(reader, entry)
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


def _fill_poses(robot: Robot, steps: list[Step]) -> tuple[Keyframe, ...]:
    """Full target vectors: a joint not named keeps its previous target (home at first)."""
    current = dict(robot.poses[HOME_POSE])
    names = robot.joint_names
    keyframes = []
    for step in steps:
        current.update(step.angles_deg)
        keyframes.append(
            Keyframe(
                targets_deg=tuple(map(current.__getitem__, names)),
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
