"""One motion file as the studio sees it: loaded, planned and simulated, or the problems that
stop it loading, with the last good result kept on screen meanwhile."""

from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from choreo.errors import ChoreoError
from choreo.motion.motion_file import Keyframe, Motion, load_motion
from choreo.preview import CheckResult, Rollout, run_checks, simulate_motion


@dataclass(frozen=True)
class Plan:
    """A motion that loaded: the plan as sent to the servos and what the simulated servos did.

    Times count from the motion's start; the approach from the start pose is before 0."""

    motion: Motion
    rollout: Rollout  # from the robot at rest in its start pose
    findings: tuple[CheckResult, ...]
    keyframe_times_s: tuple[float, ...]  # arrival at each keyframe of the first pass

    @property
    def start_s(self) -> float:
        return self.rollout.start_s

    @property
    def end_s(self) -> float:
        return self.rollout.duration_s

    def step_at(self, t_s: float) -> int:
        times = self.rollout.times_s
        return int(np.clip(np.searchsorted(times, t_s), 0, len(times) - 1))

    def planned_deg(self, t_s: float) -> np.ndarray:
        """Where the ticks ask the joints to be at ``t_s`` (no load, no lag)."""
        return self.rollout.command_deg[self.step_at(t_s)]

    def simulated_deg(self, t_s: float) -> np.ndarray:
        return self.rollout.position_deg[self.step_at(t_s)]

    def keyframe_at(self, index: int) -> tuple[Keyframe, float]:
        return self.motion.keyframes[index], self.keyframe_times_s[index]


@dataclass(frozen=True)
class Reload:
    """What one reload did: ``problems`` empty when the files loaded, planned and simulated."""

    version: int
    problems: tuple[str, ...]


def file_digest(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


class Session:
    """The motion file and what was made of it; ``reload`` is safe from any thread."""

    def __init__(self, motion_path: Path):
        self.motion_path = Path(motion_path)
        self.plan: Plan | None = None  # the last good one: kept while the files have problems
        self.problems: tuple[str, ...] = ()
        self.version = 0  # counts reloads, good or bad
        self.loaded_digest: str | None = None  # the motion file's bytes the page was built from
        self._watched: tuple[Path, ...] = (self.motion_path,)
        self._lock = threading.Lock()

    @property
    def watched_files(self) -> tuple[Path, ...]:
        """The motion file, its includes, its robot and model files and its song."""
        return self._watched

    def reload(self) -> Reload:
        with self._lock:
            digest = file_digest(self.motion_path)
            try:
                plan = make_plan(load_motion(self.motion_path))
            except ChoreoError as error:
                self.problems = tuple(str(error).splitlines())
            except OSError as error:
                self.problems = (f"{self.motion_path}: {error.strerror or error}",)
            else:
                self.plan, self.problems = plan, ()
                self._watched = files_of(plan.motion)
            self.loaded_digest = digest
            self.version += 1
            return Reload(self.version, self.problems)

    def changed_on_disk(self) -> bool:
        """The motion file is no longer the bytes last loaded (an edit the page has not seen)."""
        return file_digest(self.motion_path) != self.loaded_digest


def make_plan(motion: Motion) -> Plan:
    """Plan and simulate ``motion`` as ``choreo preview`` does, without rendering."""
    rollout = simulate_motion(motion).since_start()
    times = rollout.keyframe_times_s[: len(motion.keyframes)]
    return Plan(motion, rollout, tuple(run_checks(rollout)), tuple(float(t) for t in times))


def files_of(motion: Motion) -> tuple[Path, ...]:
    robot = motion.robot
    paths = [motion.path, robot.path, robot.mjcf_path, robot.scene_path]
    for keyframe in motion.keyframes:
        paths.append(keyframe.where.path)
        paths.extend(entry.path for entry in keyframe.where.included_at)
    if motion.music is not None:
        paths.append(motion.music.song)
    unique = dict.fromkeys(Path(p).resolve() for p in paths if p is not None)
    return tuple(unique)
