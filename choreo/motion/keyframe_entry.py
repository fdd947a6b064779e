"""One entry of a motion file's keyframes as written: a keyframe's pose (a pose name or joint
angles), its timing (``t``, ``after``, or a beat or bar of the music), hold, stop and velocity, its
sites or body, or a ``gait:`` block; and the include chain it was read through. What
:mod:`choreo.motion.motion_file` reads the whole file with."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml

from choreo.core.file_shape import mapping_shape
from choreo.core.yaml_source import (
    Entry,
    Node,
    Reader,
    SourceLocation,
    describe,
    did_you_mean,
    fmt,
    quoted,
)
from choreo.motion.gait import BodyPose
from choreo.motion.music_block import BeatRef, Music, read_beat_time
from choreo.motion.spatial import (
    GaitEnd,
    SiteTarget,
    Spatial,
    read_body,
    read_gait,
    read_sites,
)
from choreo.motion.timing import (
    MAX_TIME_S,
)
from choreo.robot.poses import read_angles
from choreo.robot.types import Robot

# The slowest a keyframe's velocity may ask for: 1 % of the joints' velocity limits (3 deg/s for
# an LX-16A: 240° in 80 s). Far below that, a move outlasts what can be planned between two
# keyframes, and ruckig fails on its numbers (velocity: 1.0e-300).
MIN_VELOCITY_SCALE = 0.01


KEYFRAME = mapping_shape("motion", "#/$defs/poseKeyframe")


GAIT = mapping_shape("motion", "#/$defs/gaitBlock")


TIMING_KEYS = ("t", "after", "beat", "bar")  # bar and beat together are one time


@dataclass(frozen=True)
class Step:
    """A keyframe as written, before partial poses are filled in: only the joints it names."""

    angles_deg: Mapping[str, float]
    where: SourceLocation
    t_s: float | None
    after_s: float | None
    hold_s: float
    stop: bool
    velocity_scale: float
    label: str
    t_where: SourceLocation | None  # where its t was written, while it still has one
    space: Spatial | None = None  # sites:, body: or gait:, until solved into joint angles
    beat: BeatRef | None = None  # its t was written as a beat or bar
    sites: tuple[SiteTarget, ...] = ()  # the sites: it was written with, once solved
    body: BodyPose | None = None  # the body: it was written with, once solved
    gait_end: GaitEnd | None = None  # it ends a gait: block


@dataclass(frozen=True)
class Include:
    """One link of an include chain: the file and the include entry that brought it in."""

    path: Path
    entry: SourceLocation | None  # None for the motion file itself
    music: Music | None = None  # the including motion's music, inherited along the chain
    music_refused: bool = False  # its music block had a problem (reported there)


def read_keyframe(reader: Reader, item: Node, robot: Robot, top: Include) -> Step | None:
    fields = reader.fields(item, "a keyframe", KEYFRAME.keys)
    if fields is None:
        return None
    space = read_space(reader, item, fields)
    if space is False:
        return None
    pose = read_pose(reader, fields["pose"].value, robot) if "pose" in fields else ({}, "")
    timing = read_timing(reader, fields, top)
    hold_s = (
        reader.number(fields["hold"].value, "hold", low=0, high=MAX_TIME_S, unit=" s")
        if "hold" in fields
        else 0.0
    )
    stop = reader.boolean(fields["stop"].value, "stop") if "stop" in fields else None
    velocity = (
        reader.number(fields["velocity"].value, "velocity", low=MIN_VELOCITY_SCALE, high=1)
        if "velocity" in fields
        else 1.0
    )
    if hold_s and stop is False:
        reader.report(
            fields["stop"].value,
            f"stop: false contradicts hold {fmt(hold_s)}: a hold "
            f"always comes to rest; remove stop: false",
        )
    if (
        pose is None
        or timing is None
        or hold_s is None
        or velocity is None
        or "stop" in fields
        and stop is None
    ):
        return None
    angles, label = pose
    t_s, after_s, beat = timing
    return Step(
        angles,
        reader.where(item),
        t_s,
        after_s,
        hold_s=hold_s,
        stop=bool(stop or hold_s),
        velocity_scale=velocity,
        label=label,
        t_where=t_where(reader, fields),
        space=space,
        beat=beat,
    )


def read_space(
    reader: Reader, item: Node, fields: dict[str, Entry]
) -> Spatial | None | Literal[False]:
    """The keyframe's sites: or body: (at most one), None if neither, False if refused."""
    given = [key for key in ("sites", "body") if key in fields]
    if not given and "pose" not in fields:
        reader.report(item, "a keyframe needs pose, sites or body (or a mix of pose and one)")
        return False
    if len(given) > 1:
        reader.report(fields["body"].key_node, "give sites or body in a keyframe, not both")
        return False
    if not given:
        return None
    value = fields[given[0]].value
    space = read_sites(reader, value) if given[0] == "sites" else read_body(reader, value)
    return False if space is None else space


def read_gait_block(reader: Reader, item: Node) -> list[Step]:
    fields = reader.fields(item, "a gait block (only gait: {...})", GAIT.keys)
    node = fields["gait"].value if fields and "gait" in fields else None
    spec = read_gait(reader, node) if node is not None else None
    if node is None or spec is None:
        return []
    return [Step({}, reader.where(item), None, None, 0.0, True, 1.0, "", None, space=spec)]


def t_where(reader: Reader, fields: dict[str, Entry]) -> SourceLocation | None:
    """Where an absolute time (t, beat or bar) was written."""
    key = next((k for k in ("t", "beat", "bar") if k in fields), None)
    return reader.where(fields[key].value) if key else None


def read_timing(
    reader: Reader, fields: dict[str, Entry], top: Include
) -> tuple[float | None, float | None, BeatRef | None] | None:
    """(t_s, after_s, beat) of a keyframe or include entry; None if refused (reported).

    A beat or bar becomes its t (seconds of the music's beat grid of ``top``, the motion file);
    with a music block already refused, it is refused without a word more."""
    given = [fields[k] for k in TIMING_KEYS if k in fields]
    if len({"t" if e.key == "t" else "after" if e.key == "after" else "beat" for e in given}) > 1:
        later = max(given, key=lambda e: e.key_node.start_mark.index)
        beat = ", beat/bar (a beat of the music)" if "beat" in fields or "bar" in fields else ""
        reader.report(
            later.key_node,
            "give at most one of t (arrival time from the motion "
            f"start){beat} and after (delay after the previous keyframe); remove one",
        )
        return None
    if "beat" in fields or "bar" in fields:
        if top.music_refused:
            return None
        resolved = read_beat_time(reader, fields, top.music)
        return None if resolved is None else (resolved[0], None, resolved[1])
    seconds: dict[str, Any] = {"low": 0, "high": MAX_TIME_S, "unit": " s"}
    t_s = reader.number(fields["t"].value, "t", **seconds) if "t" in fields else None
    after_s = (
        reader.number(fields["after"].value, "after", **seconds) if "after" in fields else None
    )
    if ("t" in fields and t_s is None) or ("after" in fields and after_s is None):
        return None
    return t_s, after_s, None


def read_pose(reader: Reader, node: Node, robot: Robot) -> tuple[dict[str, float], str] | None:
    """A pose name or a (partial) ``joint: degrees`` mapping, with its label."""
    if isinstance(node, yaml.ScalarNode) and node.tag.endswith(":str"):
        if node.value in robot.poses:
            return dict(robot.poses[node.value]), node.value
        reader.report(
            node,
            f"unknown pose {quoted(node.value)}{did_you_mean(node.value, robot.poses)}; "
            f"robot {robot.name!r} has poses {', '.join(robot.poses)}; or give "
            f"joint angles as {{joint: degrees}}",
        )
        return None
    if not isinstance(node, yaml.MappingNode):
        reader.report(
            node,
            f"pose must be a pose name ({', '.join(robot.poses)}) or a mapping "
            f"joint: degrees, got {describe(node)}",
        )
        return None
    angles = read_angles(reader, node, "pose", robot.joints_by_name)
    if angles is None:
        return None
    accepted = {name: angle for name, angle in angles.items() if angle is not None}
    if len(accepted) < len(angles):  # a refused angle was reported
        return None
    return accepted, ""
