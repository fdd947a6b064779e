"""Robots and motions built in code for the planner, segmenter and plan CLI tests."""

from __future__ import annotations

from pathlib import Path

from choreo.motion import Keyframe, Motion
from choreo.robot import Joint, JointLimits, Robot, SourceLocation

MOTION_PATH = Path("test_motion.yaml")


def make_robot(n_joints: int = 6, *, span_deg: float = 90.0, vel: float = 300.0,
               acc: float = 3000.0, jerk: float = 30000.0, name: str = "bot") -> Robot:
    """Joints j0..j{n-1}: limits ±span, servo zero at 500, alternating directions."""
    joints = tuple(
        Joint(name=f"j{i}", servo_id=i + 1, servo_model="LX-16A", zero_units=500.0,
              direction=1 if i % 2 == 0 else -1,
              limits=JointLimits(-span_deg, span_deg, vel, acc, jerk), mjcf_joint=f"j{i}")
        for i in range(n_joints))
    home = {j.name: 0.0 for j in joints}
    return Robot(name=name, path=Path(f"models/{name}/robot.yaml"), joints=joints,
                 poses={"home": home})


def kf(targets, line: int, *, t=None, after=None, hold=0.0, stop=False,
       velocity=1.0) -> Keyframe:
    return Keyframe(targets_deg=tuple(float(x) for x in targets),
                    where=SourceLocation(MOTION_PATH, line, 5), t_s=t, after_s=after,
                    hold_s=hold, stop=stop or hold > 0, velocity_scale=velocity)


def make_motion(robot: Robot, keyframes, *, speed: float = 1.0, repeat: int = 1) -> Motion:
    return Motion(name="test", path=MOTION_PATH, robot=robot, keyframes=tuple(keyframes),
                  speed=speed, repeat=repeat)
