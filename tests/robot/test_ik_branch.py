"""IK that stays on its branch: the solution nearest the previous keyframe, joints the task does
not constrain left where they were, and a warning at the keyframe when a small move in space
still needs a large move in joints."""

from __future__ import annotations

import numpy as np
import pytest
from paths import REPO

from choreo.motion.motion_file import load_motion
from choreo.preview import CheckKind, Severity, run_checks, simulate_motion
from choreo.robot.kinematics import Kinematics, SiteGoal
from choreo.robot.robot_file import load_robot


@pytest.fixture(scope="module")
def arm6():
    return Kinematics(load_robot(REPO / "models" / "arm6" / "robot.yaml"))


def test_a_small_tool_move_leaves_the_wrist_roll_alone(arm6):
    """A 7.6 mm tool move (position and pitch) from a pose where the first descent gets stuck:
    the restarts used to re-draw the wrist roll too, which moves neither the tool point (on its
    axis) nor its pitch, and kept whatever they found (wrist_roll +38°). Now it stays, and every
    joint moves only a little."""
    seed = np.array([13.1, -54.3, -1.1, -74.9, -3.9, 32.2])
    start = arm6.site_pose("tool", seed)
    goal = SiteGoal("tool", tuple(start.position_mm + [3.41, -5.02, 4.64]), start.pitch_deg)
    solution = arm6.solve([goal], seed)
    assert solution.ok
    roll = arm6.robot.joint_names.index("wrist_roll")
    assert solution.angles_deg[roll] == seed[roll]
    assert np.abs(solution.angles_deg - seed).max() < 5


def test_the_solution_nearest_the_seed_is_kept(arm6):
    """From a pose reaching up and back over the base, a 9 mm move has no solution near the
    seed; of the restarts that reach it, the nearest one is kept (the old search kept the first
    it found: base_yaw +183°, wrist_pitch -126°, wrist_roll +146°)."""
    seed = np.array([-68.5, -59.0, 7.2, 76.9, -83.2, 12.5])
    start = arm6.site_pose("tool", seed)
    goal = SiteGoal("tool", tuple(start.position_mm + [-7.3, 3.28, 4.83]), start.pitch_deg)
    solution = arm6.solve([goal], seed)
    assert solution.ok
    moved = dict(zip(arm6.robot.joint_names, np.abs(solution.angles_deg - seed)))
    assert moved["base_yaw"] < 10 and moved["wrist_roll"] == 0
    assert max(moved.values()) < 120


def test_a_straight_line_in_small_steps_stays_on_its_branch(arm6):
    """The tool drawn 100 mm sideways in 5 mm steps, pitch kept, each solve seeded by the one
    before as a motion's keyframes are: every step is reached and turns no joint more than 6°
    (5 mm at the tool, ~200 mm from the shoulder, is under 2° of base yaw), so the arm never
    changes branch on the way."""
    angles = np.array([30.0, 20.0, 60.0, 60.0, 0.0, 20.0])
    start = arm6.site_pose("tool", angles)
    for step in range(1, 21):
        at = start.position_mm + [0.0, -5.0 * step, 0.0]
        solution = arm6.solve([SiteGoal("tool", tuple(at), start.pitch_deg)], angles)
        assert solution.ok, step
        assert np.abs(solution.angles_deg - angles).max() < 6, step
        angles = solution.angles_deg


def test_a_small_move_needing_a_large_joint_move_is_warned_at_its_keyframe():
    motion = load_motion(REPO / "tests" / "data" / "spatial" / "branch_jump.yaml")
    simulated = simulate_motion(motion)
    (jump,) = [r for r in run_checks(simulated) if r.kind is CheckKind.JOINT_JUMP]
    assert jump.severity is Severity.WARNING and jump.value > 45
    assert jump.time_s == pytest.approx(simulated.rollout.keyframe_times_s[1])
    (found,) = simulated.joint_jumps
    assert found.moved_mm < 20 and found.where.line == 9
