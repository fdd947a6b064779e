"""A gait too fast for the joint limits gets one message at its gait: line naming the shortest
period that works, instead of one `after >=` line per keyframe (advice a gait cannot take)."""

from __future__ import annotations

from pathlib import Path

import pytest
from paths import REPO

from choreo.errors import PlanningError
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion

ROBOT = REPO / "models" / "hexapod18" / "robot.yaml"


def gait_motion(tmp_path: Path, *gaits: str) -> Path:
    path = tmp_path / f"walk{len(list(tmp_path.iterdir()))}.yaml"
    blocks = "".join(f"  - gait: {{{gait}}}\n" for gait in gaits)
    path.write_text(
        f"robot: {ROBOT.as_posix()}\nkeyframes:\n  - pose: home\n  - pose: home\n{blocks}"
    )
    return path


def test_a_gait_too_fast_gets_one_line_with_the_shortest_period(tmp_path):
    path = gait_motion(
        tmp_path,
        "pattern: tripod, steps: 2, stride: 40, lift: 30, period: 0.5",
        "pattern: wave, steps: 2, stride: 40, lift: 30",
    )
    with pytest.raises(PlanningError) as caught:
        plan_motion(load_motion(path))
    lines = str(caught.value).splitlines()
    assert len(lines) == 2  # one per gait block, not one per keyframe
    assert lines[0].startswith(f"{path}:5:5: gait: a step every 0.5 s is faster")
    assert "shortest period that works is 1 s; give period: 1 " in lines[0]
    assert lines[1].startswith(f"{path}:6:5: gait: a step every 2 s")
    assert "after >=" not in str(caught.value)


def test_the_period_named_works_and_a_tenth_less_does_not(tmp_path):
    wave = "pattern: wave, steps: 2, stride: 40, period: {}"
    plan_motion(load_motion(gait_motion(tmp_path, wave.format(3.1))))
    with pytest.raises(PlanningError, match="shortest period that works is 3.1 s"):
        plan_motion(load_motion(gait_motion(tmp_path, wave.format(3.0))))


def test_other_keyframes_too_early_keep_their_own_advice(tmp_path):
    path = tmp_path / "quick.yaml"
    path.write_text(
        f"robot: {ROBOT.as_posix()}\nkeyframes:\n  - pose: home\n"
        "  - pose: {lf_femur: 80}\n    after: 0.05\n"
        "  - gait: {pattern: tripod, steps: 1, stride: 40, period: 0.5}\n"
    )
    with pytest.raises(PlanningError) as caught:
        plan_motion(load_motion(path))
    lines = str(caught.value).splitlines()
    assert "after >=" in lines[0] and ":4:5:" in lines[0]
    assert "shortest period" in lines[-1] and ":6:5:" in lines[-1]


def test_the_shortest_period_is_for_the_servos_at_the_robots_supply(tmp_path):
    """The LX-224HV's datasheet speed is at 11.1 V; at 6.5 V its speed (and its default
    velocity limit for planning) is 6.5/11.1 of that, and a robot file's measured no-load speed
    counts too. A tripod step of 1 s, fine at 11.1 V, is too fast at 6.5 V: the advice names
    the period that fits the slower servos. (At 6 V the tripod's three feet down need more than
    the femurs' stall torque, at any period: tests/motion/test_stance_load.py.)"""
    import shutil

    from choreo.bus.servo_models import servo_model

    models = tmp_path / "models"
    shutil.copytree(ROBOT.parent, models / "hexapod18")
    robot_file = models / "hexapod18" / "robot.yaml"
    text = robot_file.read_text()
    walk = "pattern: tripod, steps: 4, stride: 40, lift: 30, period: 1.0"

    def shortest_with(robot_text: str) -> tuple[float, str | None]:
        robot_file.write_text(robot_text)
        path = tmp_path / "walk.yaml"
        path.write_text(
            f"robot: {robot_file.as_posix()}\nkeyframes:\n  - pose: home\n  - gait: {{{walk}}}\n"
        )
        motion = load_motion(path)
        try:
            plan_motion(motion)
        except PlanningError as error:
            return motion.robot.joints[0].limits.vel_deg_s, str(error)
        return motion.robot.joints[0].limits.vel_deg_s, None

    rated = servo_model("LX-224HV").vel_limit_deg_s
    assert shortest_with(text) == (pytest.approx(rated), None)
    velocity, advice = shortest_with(text.replace("defaults:", "bus:\n  supply_v: 6.5\ndefaults:"))
    assert velocity == pytest.approx(rated * 6.5 / 11.1)
    assert advice is not None and "shortest period that works is 1.4 s" in advice
    slower = "defaults:\n  actuator: {no_load_speed_deg_s: 200}"
    velocity, advice = shortest_with(text.replace("defaults:", slower, 1))
    assert velocity == pytest.approx(0.8 * 200)
    assert advice is not None and "shortest period that works is 1.3 s" in advice
