"""A motion previewed end to end: planned and compiled into the ticks ``choreo play`` sends, the
player's approach from the start pose added (a ``Rehearsal``: ``rehearsal_of``), played to the
simulated robot (``sim.simulate``), and the rollout measured against what the motion asked: a
walker's stance and gaits, its ``sites:`` targets (``simulate_motion``, ``simulate_rehearsal``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from choreo.core.arguments import check_text, check_type
from choreo.errors import OptionError
from choreo.motion.motion_file import HOME_POSE, Keyframe, Motion, motion_of
from choreo.motion.scene import StartPosture
from choreo.motion.timing import PlayedKeyframe, played_keyframes
from choreo.plan.performance import Performance, prepare
from choreo.plan.pipeline import PlanOptions, compile_motion, plan_options
from choreo.plan.ticks import DEFAULT_TOLERANCE_DEG
from choreo.preview.actuator import CommandStream, commanded_path_units
from choreo.preview.impact import Impact, impacts
from choreo.preview.model import load_model
from choreo.preview.reach import JointJump, SiteReach, SitesDue, joint_jumps, site_reach
from choreo.preview.rollout import Rollout
from choreo.preview.sim import SimSettings, simulate
from choreo.preview.simulated import SimulatedMotion
from choreo.preview.stance import feet_and_centre, floors_kept, planned_stance
from choreo.preview.step_loop import Resume
from choreo.preview.walk import GaitDue, Walk
from choreo.robot.kinematics import Kinematics

FIRST_KEYFRAME = "first"  # start pose name meaning the motion's first keyframe


@dataclass(frozen=True)
class Rehearsal:
    """The ``Performance`` the player would give of a motion (the approach from its start pose,
    then the motion's ticks), with the motion and the start pose it is played from: what the
    simulation plays, and the plan without the physics."""

    motion: Motion
    start_deg: tuple[float, ...]
    performance: Performance
    speed: float  # the motion's own speed, or the one asked for

    @property
    def approach_s(self) -> float:
        return self.performance.approach_s

    @property
    def keyframe_times_s(self) -> tuple[float, ...]:
        """Arrival at each played keyframe, from the motion's start (after the approach)."""
        return tuple(float(t) for t in self.performance.trajectory.keyframe_times_s)

    def stream(self) -> CommandStream:
        return CommandStream.from_ticks(self.performance.ticks, len(self.motion.robot.joints))

    def end_s(self, settings: SimSettings | None = None) -> float:
        """Where its simulation ends: the last move, then the settings' tail."""
        return self.stream().end_s + (settings or SimSettings()).tail_s - self.approach_s

    def commanded_deg(self, times_s: np.ndarray) -> np.ndarray:
        """Where the ticks ask the joints to be at ``times_s`` (from the motion's start; the
        approach before 0): no load, no lag, as ``Rollout.command_deg``."""
        robot, stream = self.motion.robot, self.stream()
        start_units = robot.to_units(np.asarray(self.start_deg))
        times = np.asarray(times_s, dtype=float) + self.approach_s
        return robot.to_deg(commanded_path_units(stream, start_units, times))


def rehearsal_of(
    motion: Motion | str | os.PathLike[str],
    *,
    plan: PlanOptions | None = None,
    start_pose: str | None = None,
) -> Rehearsal:
    """Plan ``motion`` and compile it into ticks as ``choreo play`` does (the same ``plan``), with
    the approach the player would play from the start pose (see ``simulate_motion``); no
    physics."""
    motion = motion_of(motion)
    plan = PlanOptions() if plan is None else plan
    check_text("start_pose", start_pose, optional=True)
    compiled = compile_motion(motion, plan)
    start_deg = start_pose_deg(motion, compiled.trajectory.at(0.0)[0], start_pose)
    return Rehearsal(
        motion,
        tuple(start_deg),
        prepare(compiled, start_deg),
        motion.speed if plan.speed is None else plan.speed,
    )


def simulate_motion(
    motion: Motion | str | os.PathLike[str],
    settings: SimSettings | None = None,
    *,
    plan: PlanOptions | None = None,
    speed: float | None = None,
    stretch: bool = False,
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
    start_pose: str | None = None,
) -> SimulatedMotion:
    """Plan ``motion`` and compile it into ticks as ``choreo play`` does (as ``plan`` says, or
    without it ``speed``, ``stretch`` and ``tolerance_deg``), add the approach the player would
    play from the start pose, play it all to the simulated robot, and measure the rollout
    against what the motion asked.

    The start pose is the robot's pose ``start_pose``, or "first" for the motion's first
    keyframe; by default ``home`` (the first keyframe for a motion that starts lying, or a
    robot without a home pose). ``motion`` may be given by its file's path.
    """
    if settings is not None:
        check_type("settings", settings, SimSettings, "a SimSettings, or None")
    plan = plan_options(plan, speed, stretch, tolerance_deg)
    rehearsal = rehearsal_of(motion, plan=plan, start_pose=start_pose)
    return simulate_rehearsal(rehearsal, settings)


def simulate_rehearsal(
    rehearsal: Rehearsal, settings: SimSettings | None = None, resume: Resume | None = None
) -> SimulatedMotion:
    """Play a rehearsal's ticks to the simulated robot (``simulate_motion``'s physics);
    ``resume``: an earlier rollout's, to reuse what it simulated before the first tick that
    differs (``simulate``)."""
    motion, performance = rehearsal.motion, rehearsal.performance
    rollout = simulate(
        motion.robot,
        performance.ticks,
        rehearsal.start_deg,
        keyframe_times_s=rehearsal.keyframe_times_s,
        settings=settings or SimSettings(),
        motion_start_s=performance.approach_s,
        posture=motion.start,
        props=motion.props,
        resume=resume,
    )
    played = played_keyframes(motion.keyframes, repeat=motion.repeat, speed=rehearsal.speed)
    reach, jumps = _sites(rollout, motion, played)
    return SimulatedMotion.of(
        rollout,
        end=motion.end,
        walk=_walk(rollout, motion, played),
        site_reach=reach,
        joint_jumps=jumps,
        impacts=_impacts(rollout, motion),
    )


def _impacts(rollout: Rollout, motion: Motion) -> tuple[Impact, ...]:
    """How a free-floating robot that means to end lying comes down (any other touch of the
    ground is a fall already, and is not measured)."""
    if rollout.body is None or not motion.end.lying:
        return ()
    return tuple(impacts(rollout, load_model(motion.robot, motion.props)))


def _walk(
    rollout: Rollout, motion: Motion, played: Sequence[PlayedKeyframe[Keyframe]]
) -> Walk | None:
    """A walker's planned stance, where its feet and centre of mass really were and its gait:
    blocks' times; None for a robot fixed to the world or without foot sites."""
    if rollout.body is None:
        return None
    kin = Kinematics(motion.robot)
    if not kin.feet():
        return None
    model = load_model(motion.robot, motion.props)
    arrivals = rollout.keyframe_times_s
    gaits = tuple(
        GaitDue(arrivals[max(i - end.keyframes, 0)], arrivals[i], end.gait, end.where)
        for i, p in enumerate(played)
        if (end := p.keyframe.gait_end) is not None
    )
    feet, centre = feet_and_centre(kin, model, rollout.qpos)
    # heading for each keyframe (holding it: for the next), the floor its targets keep
    kept = floors_kept(
        kin,
        [p.keyframe.targets_deg for p in played],
        [p.keyframe.body is not None for p in played],
    )
    heading = np.searchsorted(np.asarray(arrivals), rollout.times_s - 1e-9)
    by_step = [kept[k] for k in np.clip(heading, 0, len(kept) - 1)] if kept else None
    stance = planned_stance(kin, model, rollout.command_deg, rollout.times_s, by_step)
    return Walk(stance, feet, centre, gaits)


def _sites(
    rollout: Rollout, motion: Motion, played: Sequence[PlayedKeyframe[Keyframe]]
) -> tuple[tuple[SiteReach, ...], tuple[JointJump, ...]]:
    """Each ``sites:`` target against where its site was when due, and the keyframes IK met
    with a large joint move."""
    due = [
        SitesDue(index, arrival, p.hold_s, p.keyframe.sites)
        for index, (p, arrival) in enumerate(zip(played, rollout.keyframe_times_s))
        if p.keyframe.sites
    ]
    if not due:
        return (), ()
    kin = Kinematics(motion.robot)
    model = load_model(motion.robot, motion.props)
    reach = site_reach(
        model, rollout.qpos, rollout.times_s, due, kin.base_body, kin.world_to_base_mm
    )
    targets = [p.keyframe.targets_deg for p in played]
    return reach, joint_jumps(kin, due, targets, motion.robot.joint_names)


def start_pose_deg(motion: Motion, first_deg, start_pose: str | None) -> tuple[float, ...]:
    """Where the robot is before the approach (see ``simulate_motion``)."""
    robot = motion.robot
    if start_pose is None:
        lying = motion.start is not StartPosture.STANDING
        start_pose = "first" if lying or HOME_POSE not in robot.poses else HOME_POSE
    if start_pose == FIRST_KEYFRAME:
        return tuple(float(a) for a in first_deg)
    if start_pose not in robot.poses:
        raise OptionError(
            "start_pose",
            f"{start_pose!r}: no such pose in {robot.path}; start from one of "
            f"{', '.join([*robot.poses, FIRST_KEYFRAME])}",
        )
    return robot.pose_vector(start_pose)
