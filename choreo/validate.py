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

from choreo.errors import PlanningError, SourceError
from choreo.motion.motion_file import Motion, load_motion
from choreo.motion.music_block import past_song
from choreo.plan.pipeline import compile_motion
from choreo.robot.lookup import ROBOT_FILE
from choreo.robot.robot_file import load_robot
from choreo.show.showfile import is_show_file, load_show


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
            load_robot(path)
            return FileCheck(path)
        if is_show_file(path):
            return _check_show(path, physics=physics, stretch=stretch)
        motion = load_motion(path, allow_past_song)
        compiled = compile_motion(motion, stretch=stretch)
    except SourceError as error:
        return FileCheck(path, list(error.problems))
    except PlanningError as error:  # one line per problem, each path:line:col
        return FileCheck(path, str(error).splitlines())
    stretched = [s.describe() for s in compiled.stretches]
    outlasts = past_song(motion.music, motion.keyframes, motion.repeat)
    stretched += [f"{path}: {outlasts}"] if outlasts else []
    if not physics:
        return FileCheck(path, warnings=stretched)
    found = _physics_check(path, motion, compiled.trajectory.keyframe_times_s, stretch)
    return FileCheck(path, found.problems, stretched + found.warnings)


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
    from choreo.preview import Severity, run_checks, simulate_motion  # mujoco: only when asked for

    results = run_checks(simulate_motion(motion, stretch=stretch))
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
