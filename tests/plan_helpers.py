"""Robots and motions built in code for the planner, segmenter and plan CLI tests."""

from __future__ import annotations

import functools
from pathlib import Path

import ruckig
from hypothesis import strategies as st

from choreo.core.yaml_source import SourceLocation
from choreo.motion.motion_file import Keyframe, Motion, load_motion
from choreo.plan.planner import PlanResult, plan_motion
from choreo.robot.types import Joint, JointLimits, Robot

MOTION_PATH = Path("test_motion.yaml")


def make_robot(
    n_joints: int = 6,
    *,
    span_deg: float = 90.0,
    vel: float = 300.0,
    acc: float = 3000.0,
    jerk: float = 30000.0,
    name: str = "bot",
) -> Robot:
    """Joints j0..j{n-1}: limits ±span, servo zero at 500, alternating directions."""
    joints = tuple(
        Joint(
            name=f"j{i}",
            servo_id=i + 1,
            servo_model="LX-16A",
            zero_units=500.0,
            direction=1 if i % 2 == 0 else -1,
            limits=JointLimits(-span_deg, span_deg, vel, acc, jerk),
            mjcf_joint=f"j{i}",
        )
        for i in range(n_joints)
    )
    home = {j.name: 0.0 for j in joints}
    return Robot(
        name=name, path=Path(f"models/{name}/robot.yaml"), joints=joints, poses={"home": home}
    )


def kf(targets, line: int, *, t=None, after=None, hold=0.0, stop=False, velocity=1.0) -> Keyframe:
    return Keyframe(
        targets_deg=tuple(float(x) for x in targets),
        where=SourceLocation(MOTION_PATH, line, 5),
        t_s=t,
        after_s=after,
        hold_s=hold,
        stop=stop or hold > 0,
        velocity_scale=velocity,
    )


def make_motion(robot: Robot, keyframes, *, speed: float = 1.0, repeat: int = 1) -> Motion:
    return Motion(
        name="test",
        path=MOTION_PATH,
        robot=robot,
        keyframes=tuple(keyframes),
        speed=speed,
        repeat=repeat,
    )


ROBOTS = {6: make_robot(6), 18: make_robot(18, acc=2500, jerk=20000, vel=250)}

# What ``motions`` draws, each strategy made once: made anew at every draw, hypothesis checked
# each one again (validation, emptiness) for every angle of every keyframe: a quarter of the CPU of
# the planner's random-motion test. The same strategies drawn in the same order: the same motions.
_ROBOT_SIZE = st.sampled_from(sorted(ROBOTS))
_COUNT = st.integers(1, 7)
_TARGET = st.one_of(
    st.floats(-90, 90, allow_nan=False).map(lambda a: round(a, 2)),  # anywhere in the limits
    st.sampled_from([-90.0, -88.0, 89.5, 90.0]),  # at them or near
)
_TIMING = st.sampled_from(["t", "after", "asap"])
_GAP = st.floats(0.05, 1.2)
_HOLD = st.sampled_from([0.0, 0.0, 0.0, 0.2])
_STOP = st.booleans()
_VELOCITY = st.sampled_from([1.0, 1.0, 0.5])
_SPEED = st.sampled_from([1.0, 1.0, 0.5, 2.0])
_REPEAT = st.sampled_from([1, 1, 2])


@st.composite
def motions(draw):
    """Random keyframe sets on a 6-joint arm-like or an 18-joint robot: angles anywhere in the
    limits and often at them, every kind of timing (some infeasible), holds, stops, velocity
    scales, speeds and repeats."""
    robot = ROBOTS[draw(_ROBOT_SIZE)]
    n = len(robot.joints)
    count = draw(_COUNT)
    t = 0.0
    keyframes = []
    for line in range(1, count + 1):
        targets = [draw(_TARGET) for _ in range(n)]
        timing = draw(_TIMING)
        gap = draw(_GAP)
        hold = draw(_HOLD)
        extra = {}
        if timing == "t" and line > 1:
            t += gap
            extra["t"] = round(t, 3)
        elif timing == "after" and line > 1:
            extra["after"] = round(gap, 3)
        keyframes.append(
            kf(targets, line, hold=hold, stop=draw(_STOP), velocity=draw(_VELOCITY), **extra)
        )
        t += hold + 1.0  # leave room for untimed keyframes before the next t
    return make_motion(robot, keyframes, speed=draw(_SPEED), repeat=draw(_REPEAT))


POS_EPS = 1e-6


def ruckig_rest_to_rest(robot, start, target, scale=1.0):
    """Ruckig's own answer (the reference the planner's polynomials must reproduce)."""
    n = len(robot.joints)
    inp = ruckig.InputParameter(n)
    inp.current_position, inp.target_position = list(start), list(target)
    inp.current_velocity = inp.current_acceleration = [0.0] * n
    inp.target_velocity = inp.target_acceleration = [0.0] * n
    inp.max_velocity = [j.limits.vel_deg_s * scale for j in robot.joints]
    inp.max_acceleration = [j.limits.acc_deg_s2 * scale for j in robot.joints]
    inp.max_jerk = [j.limits.jerk_deg_s3 * scale for j in robot.joints]
    out = ruckig.Trajectory(n)
    assert ruckig.Ruckig(n).calculate(inp, out) == ruckig.Result.Working
    return out


@functools.cache
def shipped_plan(path: Path) -> tuple[Motion, PlanResult]:
    """A shipped motion and its plan, once per process for the planner's and the ticks' tests
    of every shipped motion, which only read them (a walk's gait is solved by IK as it loads:
    half a second for hexapod18/side_step)."""
    motion = load_motion(path)
    return motion, plan_motion(motion)
