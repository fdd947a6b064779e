"""Generated motions for the planner benchmarks: a dance-like random walk on any robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from choreo.core.yaml_source import SourceLocation
from choreo.motion.motion_file import Keyframe, Motion
from choreo.robot.types import Joint, JointLimits, Robot

VELOCITY, ACCELERATION, JERK = 300.0, 3000.0, 30000.0  # LX-16A defaults (choreo.bus.servo_models)


def servo_robot(n_joints: int, *, name: str = "bench") -> Robot:
    """LX-16A-like joints (±90°, 300°/s, 3000°/s², 30000°/s³), servo zero at 500."""
    joints = tuple(
        Joint(
            f"j{i}",
            i + 1,
            "LX-16A",
            500.0,
            1,
            JointLimits(-90.0, 90.0, VELOCITY, ACCELERATION, JERK),
            f"j{i}",
        )
        for i in range(n_joints)
    )
    return Robot(name, Path(f"{name}/robot.yaml"), joints, {"home": {j.name: 0.0 for j in joints}})


def dance(robot: Robot, n_keyframes: int, duration_s: float, *, seed: int = 0) -> Motion:
    """Keyframes every ``duration_s / n_keyframes`` on average: a third timed with t, a third with
    after, a third as soon as possible; one in ten a stop, one in forty a short hold. Each step
    is small enough for its gap, so the times can (nearly always) be met."""
    rng = np.random.default_rng(seed)
    path = Path(f"{robot.name}_dance.yaml")
    n = len(robot.joints)
    pose = np.zeros(n)
    # 10° inside every joint's limits (±80° on servo_robot's joints)
    low = np.array([j.limits.min_deg for j in robot.joints]) + 10
    high = np.array([j.limits.max_deg for j in robot.joints]) - 10
    mean_gap = duration_s / n_keyframes
    keyframes = [Keyframe(tuple(pose), SourceLocation(path, 1, 3), t_s=0.0, stop=True)]
    t = 0.0
    for line in range(2, n_keyframes + 1):
        gap = rng.uniform(0.6, 1.4) * mean_gap
        moving = rng.random(n) < 0.7
        # at most 80 % of what the jerk limit allows from rest in this gap: d = j·T³/32
        reach = min(30.0, 0.8 * JERK * gap**3 / 32)
        step = np.clip(rng.normal(0, reach / 2, n), -reach, reach) * moving
        pose = np.clip(pose + step, low, high)
        hold = 0.2 if rng.random() < 1 / 40 else 0.0
        kind = rng.integers(3)
        timing = {"t_s": t + gap} if kind == 0 else {"after_s": gap} if kind == 1 else {}
        keyframes.append(
            Keyframe(
                tuple(float(x) for x in pose),
                SourceLocation(path, line, 3),
                hold_s=hold,
                stop=hold > 0 or rng.random() < 0.1,
                **timing,
            )
        )
        t += gap + hold
    return Motion("dance", path, robot, tuple(keyframes))
