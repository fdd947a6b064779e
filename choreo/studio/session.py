"""One motion file as the studio sees it: loaded and planned (shown at once), then simulated (shown
when the physics is done), or the problems that stop it loading, with the last good result kept
on screen meanwhile."""

from __future__ import annotations

import hashlib
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from choreo.errors import ChoreoError
from choreo.motion.motion_file import Keyframe, Motion, load_motion
from choreo.preview import (
    CheckResult,
    Rehearsal,
    Resume,
    Rollout,
    rehearsal_of,
    run_checks,
    simulate_rehearsal,
)

PLAN_STEP_S = 0.005  # the plan is sampled this finely for the timeline (the physics: 2 ms)


@dataclass(frozen=True)
class Physics:
    """What the simulated servos did with a plan's ticks, and the preview's findings."""

    rollout: Rollout  # from the robot at rest in its start pose
    findings: tuple[CheckResult, ...]
    took_s: float  # how long the simulation took

    def steps_at(self, times_s: np.ndarray) -> np.ndarray:
        """The physics step at (or just after) each of ``times_s``."""
        times = self.rollout.times_s
        return np.clip(np.searchsorted(times, times_s), 0, len(times) - 1)

    def simulated_deg(self, times_s: np.ndarray) -> np.ndarray:
        return self.rollout.position_deg[self.steps_at(times_s)]

    def qpos_at(self, t_s: float) -> np.ndarray:
        return self.rollout.qpos[int(self.steps_at(np.array([t_s]))[0])]


@dataclass(frozen=True)
class Plan:
    """A motion that loaded: the plan as sent to the servos and, once simulated (a moment after
    the plan is shown), what the simulated servos did with it.

    Times count from the motion's start; the approach from the start pose is before 0."""

    motion: Motion
    rehearsal: Rehearsal
    times_s: np.ndarray  # (n,) every PLAN_STEP_S from the approach's start to the end
    command_deg: np.ndarray  # (n, joints) where the ticks ask the joints to be
    physics: Physics | None = None

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def end_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def keyframe_times_s(self) -> tuple[float, ...]:
        """Arrival at each keyframe of the first pass."""
        return self.rehearsal.keyframe_times_s[: len(self.motion.keyframes)]

    @property
    def findings(self) -> tuple[CheckResult, ...]:
        return self.physics.findings if self.physics is not None else ()

    def planned_deg(self, t_s: float) -> np.ndarray:
        """Where the ticks ask the joints to be at ``t_s`` (no load, no lag)."""
        k = int(np.clip(np.searchsorted(self.times_s, t_s - 1e-9), 0, len(self.times_s) - 1))
        return self.command_deg[k]

    def posed_deg(self, t_s: float) -> np.ndarray:
        """The plan's pose at ``t_s`` to pose from: the planned trajectory itself (at a
        keyframe's time, the angles its file writes, not the ticks' rounding to the servos'
        steps); in the approach, the ticks'."""
        if t_s < 0:
            return np.array(self.planned_deg(t_s))
        return self.rehearsal.performance.trajectory.at(t_s)[0].copy()

    def keyframe_at(self, index: int) -> tuple[Keyframe, float]:
        return self.motion.keyframes[index], self.keyframe_times_s[index]

    @staticmethod
    def phase(t_s: float) -> str:
        return "approach" if t_s < -1e-9 else "motion"


@dataclass(frozen=True)
class Reload:
    """What one reload (or the simulation after it) did: ``problems`` empty when all went well."""

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
        self.loaded_digest: str | None = None  # the motion file's bytes last reloaded
        self.plan_digest: str | None = None  # the motion file's bytes ``plan`` was made from
        self._watched: tuple[Path, ...] = (self.motion_path,)
        self._resume: Resume | None = None  # the last simulation's: the next one starts there
        self._lock = threading.Lock()

    @property
    def watched_files(self) -> tuple[Path, ...]:
        """The motion file, its includes, its robot and model files and its song."""
        return self._watched

    def reload(self) -> Reload:
        """Load and plan the files as they are now; ``simulate`` adds the physics."""
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
                self.plan_digest = digest
                self._watched = files_of(plan.motion)
            self.loaded_digest = digest
            self.version += 1
            return Reload(self.version, self.problems)

    def simulate(self, version: int) -> Reload | None:
        """Simulate the plan reload ``version`` made (without holding the lock: the page stays
        live meanwhile); None when a newer reload came first or there is nothing to simulate."""
        with self._lock:
            plan = self.plan
            if self.version != version or plan is None or plan.physics is not None:
                return None
        try:
            physics = simulate_plan(plan, self._resume)
        except ChoreoError as error:
            problems = tuple(str(error).splitlines())
            with self._lock:
                if self.version == version:
                    self.problems = problems
            return Reload(version, problems)
        with self._lock:
            if self.version != version or self.plan is not plan:
                return None
            self.plan = replace(plan, physics=physics)
            self._resume = physics.rollout.resume
            return Reload(version, ())

    def changed_on_disk(self) -> bool:
        """The motion file is no longer the bytes last loaded (an edit the page has not seen)."""
        return file_digest(self.motion_path) != self.loaded_digest

    def plan_is_current(self) -> bool:
        """The plan shown was made from the motion file as it is on disk: its keyframes' lines
        are the file's (not so after a save that does not load or plan)."""
        return self.plan is not None and file_digest(self.motion_path) == self.plan_digest


def make_plan(motion: Motion) -> Plan:
    """Plan ``motion`` and compile its ticks as ``choreo preview`` does: no physics yet."""
    rehearsal = rehearsal_of(motion)
    count = int(np.floor((rehearsal.end_s() + rehearsal.approach_s) / PLAN_STEP_S + 1e-9)) + 1
    times = np.arange(count) * PLAN_STEP_S - rehearsal.approach_s
    return Plan(motion, rehearsal, times, rehearsal.commanded_deg(times))


def simulate_plan(plan: Plan, resume: Resume | None = None) -> Physics:
    """The preview's physics and checks for ``plan``, without rendering; what ``resume``'s
    rollout simulated before the first tick that changed is taken from it."""
    began = time.perf_counter()
    simulated = simulate_rehearsal(plan.rehearsal, resume=resume).since_start()
    findings = tuple(run_checks(simulated))
    return Physics(simulated.rollout, findings, time.perf_counter() - began)


def files_of(motion: Motion) -> tuple[Path, ...]:
    robot = motion.robot
    paths = [motion.path, robot.path, robot.mjcf_path, robot.scene_path]
    for keyframe in motion.keyframes:
        paths.append(keyframe.where.path)
        paths.extend(entry.path for entry in keyframe.where.included_at)
    if motion.music is not None:
        paths.append(motion.music.song)
    # every keyframe names its file: resolved once each (a 5-minute motion has 300 keyframes)
    unique = dict.fromkeys(Path(p) for p in paths if p is not None)
    return tuple(dict.fromkeys(p.resolve() for p in unique))
