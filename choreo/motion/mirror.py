"""A motion turned left for right with its robot's mirror pairs, as a new motion file.

Every keyframe (includes expanded, mirrored blocks already mirrored) keeps its timing, hold,
stop and velocity; only its targets are mirrored (``choreo.robot.types.mirror_targets``). Mirroring
twice gives back the original keyframes exactly. The motion's name, start, end and props are
kept, the props reflected as the robot is (``mirrored_prop``), so the preview judges the mirror
image as it judges the original.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from choreo.core.atomic import write_text_atomically
from choreo.core.yaml_source import fmt
from choreo.errors import SourceError
from choreo.motion.motion_file import Keyframe, Motion
from choreo.motion.music_block import music_text
from choreo.motion.scene import Prop
from choreo.motion.writer import motion_text, robot_reference
from choreo.robot.types import mirror_targets


def mirrored_keyframes(motion: Motion) -> tuple[Keyframe, ...]:
    """The motion's keyframes with mirrored targets; ``SourceError`` if the robot has no mirror
    pairs or a mirrored angle falls outside its joint's limits (every such angle, at its
    keyframe)."""
    robot = motion.robot
    if not robot.mirror_pairs:
        raise SourceError(
            f"{robot.path}: robot {robot.name!r} has no mirror pairs, so "
            f"{motion.path} cannot be mirrored; add 'mirror:' pairs to the robot"
        )
    problems = []
    mirrored = []
    for keyframe in motion.keyframes:
        targets = mirror_targets(robot, keyframe.targets_deg)
        for outside in robot.limit_violations(targets):
            problems.append(
                f"{keyframe.where}: mirrored, {outside.joint.name} would be at "
                f"{fmt(outside.angle_deg)}°, outside its limits {outside.joint.limits.range_text}"
            )
        mirrored.append(replace(keyframe, targets_deg=targets, label=""))
    if problems:
        raise SourceError(problems)
    return tuple(mirrored)


def mirrored_prop(prop: Prop) -> Prop:
    """``prop`` reflected in the world's x-z plane: the plane the robot's left and right mirror
    in (a robot stands at the origin facing +x, as the robot files' models do)."""

    def reflected(point):
        return None if point is None else (point[0], -point[1] + 0.0, point[2])

    return replace(
        prop,
        at_m=reflected(prop.at_m),
        yaw_deg=-prop.yaw_deg + 0.0,
        place_at_m=reflected(prop.place_at_m),
    )


def write_mirrored(motion: Motion, out: str | Path) -> tuple[Keyframe, ...]:
    """Write the mirror image of ``motion`` to ``out`` (atomically); the keyframes written."""
    keyframes = mirrored_keyframes(motion)
    out = Path(out)
    description = f"Mirror image of {motion.name}"
    if motion.description:
        description += f": {motion.description}"
    header = [
        f"Made by `choreo mirror` from {motion.path.name}:",
        "left and right swapped with the robot's mirror pairs.",
    ]
    write_text_atomically(
        out,
        motion_text(
            motion.robot,
            keyframes,
            robot_ref=robot_reference(motion.robot, out),
            description=description,
            speed=motion.speed,
            repeat=motion.repeat,
            header=header,
            music=music_text(motion.music, out) if motion.music else "",
            name=motion.name,
            start=motion.start,
            end=motion.end,
            props=tuple(mirrored_prop(prop) for prop in motion.props),
        ),
    )
    return keyframes
