"""Everything ``choreo validate`` checks, stage by stage, before anything moves.

A robot file is loaded and checked against its MuJoCo model. A motion file is loaded, planned
(every keyframe time must be reachable within the limits), compiled into ticks (every servo stays
in range, the tolerance is reachable over the bus), and simulated in the physics preview
(collisions, range hits, stalls, tracking, falls). Each stage runs only if the one before passed.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from pathlib import Path

from choreo.core.yaml_source import parse_yaml_file
from choreo.errors import PlanningError, SourceError
from choreo.motion.motion_file import Motion, motion_of_yaml
from choreo.motion.music_block import past_song
from choreo.plan.pipeline import compile_motion
from choreo.robot.lookup import ROBOT_FILE
from choreo.robot.robot_file import load_robot
from choreo.show.showfile import is_show_yaml, load_show


@dataclass(frozen=True)
class FileCheck:
    path: Path
    problems: list[str] = field(default_factory=list)  # any problem fails validation
    warnings: list[str] = field(default_factory=list)  # worth a look; validation still passes

    @property
    def ok(self) -> bool:
        return not self.problems


def check_file(
    path: Path, *, physics: bool = True, stretch: bool = False, allow_past_song: bool = False
) -> FileCheck:
    """Check one motion, robot or show file (a file named robot.yaml is a robot, one with a
    ``performers`` list a show: the show file, then every performer's motion).

    With ``stretch``, keyframes the limits can't meet on time are moved later (as ``choreo play
    --stretch`` would) and reported as warnings instead of problems.
    """
    try:
        if path.name == ROBOT_FILE:
            return FileCheck(path, [f"{path}: {p}" for p in load_robot(path).supply_problems()])
        root = parse_yaml_file(path)  # once: it tells a show from a motion, and is read as one
        if is_show_yaml(root):
            return _check_show(path, physics=physics, stretch=stretch)
        motion = motion_of_yaml(path, root, allow_past_song)
        compiled = compile_motion(motion, stretch=stretch)
    except SourceError as error:
        return FileCheck(path, list(error.problems))
    except PlanningError as error:  # one line per problem, each path:line:col
        return FileCheck(path, str(error).splitlines())
    stretched = [s.describe() for s in compiled.stretches]
    outlasts = past_song(motion.music, motion.keyframes, motion.repeat)
    stretched += [f"{path}: {outlasts}"] if outlasts else []
    robot = motion.robot
    supply = [f"{path}: robot {robot.name} ({robot.path}): {p}" for p in robot.supply_problems()]
    if not physics:
        return FileCheck(path, supply, warnings=stretched)
    found = _physics_check(path, motion, compiled.trajectory.keyframe_times_s, stretch)
    return FileCheck(path, supply + found.problems, stretched + found.warnings)


def _check_show(path: Path, *, physics: bool, stretch: bool) -> FileCheck:
    """The show file, then each performer's motion (its problems at its own lines)."""
    show = load_show(path)
    problems, warnings = [], []
    for part in show.parts:
        found = check_file(part.motion, physics=physics, stretch=stretch)
        problems += found.problems
        warnings += found.warnings
    return FileCheck(path, problems, warnings)


def _physics_check(
    path: Path, motion: Motion, arrivals_s: tuple[float, ...], stretch: bool
) -> FileCheck:
    # mujoco: only when asked for
    from choreo.preview import CheckKind, Severity, run_checks, simulate_motion

    # the supply is told once, from the robot file (``check_file``), not as a preview finding
    results = [
        r
        for r in run_checks(simulate_motion(motion, stretch=stretch))
        if r.kind is not CheckKind.SUPPLY
    ]
    lines = {
        r: f"{heading_for(motion, arrivals_s, r.time_s)}: preview: {r.message}" for r in results
    }
    return FileCheck(
        path,
        [lines[r] for r in results if r.severity is Severity.ERROR],
        [lines[r] for r in results if r.severity is Severity.WARNING],
    )


def heading_for(motion: Motion, arrivals_s: tuple[float, ...], time_s: float) -> str:
    """Where the keyframe the robot is heading for at ``time_s`` was written (``path:line:col``,
    the place a preview finding is reported at)."""
    played = bisect.bisect_left(arrivals_s, time_s)
    keyframe = motion.keyframes[min(played, len(arrivals_s) - 1) % len(motion.keyframes)]
    return str(keyframe.where)
