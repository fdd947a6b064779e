"""choreo.robot.kinematics: IK of named sites on the robots' MuJoCo models. Targets come from
MuJoCo's own forward kinematics of random in-limit joint angles, so every one of them is
reachable; the solution is checked with MuJoCo again (site_xpos, site_xmat), not with the solver's
own numbers."""

from __future__ import annotations

import functools
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from paths import REPO

from choreo.robot.kinematics import Kinematics, SiteGoal
from choreo.robot.robot_file import load_robot

MODELS = REPO / "models"
POSITION_MM, ANGLE_DEG = 1.0, 1.0  # the acceptance tolerances
# The arm stands on its table: random joint angles also curl the tool through the table or into
# its own base, targets no keyframe can mean (the solver sometimes stalls there, in a fold against
# the joint limits). Targets are kept above the table and outside the base.
ABOVE_TABLE_MM = 20.0
BASE_RADIUS_MM, BASE_TOP_MM = 60.0, 100.0


def on_the_table(position_mm: np.ndarray) -> bool:
    x, y, z = position_mm
    return z >= ABOVE_TABLE_MM and (np.hypot(x, y) >= BASE_RADIUS_MM or z >= BASE_TOP_MM)


def kinematics_of(name: str) -> Kinematics:
    return Kinematics(load_robot(MODELS / name / "robot.yaml"))


@pytest.fixture(scope="module")
def arm6() -> Kinematics:
    return kinematics_of("arm6")


@pytest.fixture(scope="module")
def hexapod() -> Kinematics:
    return kinematics_of("hexapod18")


@pytest.fixture(scope="module")
def tonypi() -> Kinematics:
    return kinematics_of("tonypi")


@functools.cache
def mujoco_model(mjcf_path: Path) -> mujoco.MjModel:
    """The model compiled from its XML by MuJoCo, once per file (not the solver's copy)."""
    return mujoco.MjModel.from_xml_path(str(mjcf_path))


@functools.cache
def mujoco_data(model: mujoco.MjModel) -> mujoco.MjData:
    """One MjData per model for ``mujoco_site`` (making one costs more than the kinematics)."""
    return mujoco.MjData(model)


def mujoco_site(kin: Kinematics, site: str, angles_deg) -> tuple[np.ndarray, float]:
    """(position mm, pitch deg) of a site in the base body's frame, computed afresh by MuJoCo."""
    robot = kin.robot
    model = mujoco_model(robot.mjcf_path)
    data = mujoco_data(model)  # reset below: nothing of the last call is left in it
    mujoco.mj_resetData(model, data)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    for joint, angle in zip(robot.joints, angles_deg):
        joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
        data.qpos[model.jnt_qposadr[joint_id]] = np.radians(angle)
    mujoco.mj_kinematics(model, data)
    site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    base_rot = data.xmat[1].reshape(3, 3)
    position = base_rot.T @ (data.site_xpos[site_id] - data.xpos[1]) * 1000
    axis = base_rot.T @ data.site_xmat[site_id].reshape(3, 3)[:, 2]
    return position, float(np.degrees(np.arcsin(np.clip(axis[2], -1, 1))))


def random_angles(kin: Kinematics, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(kin.lower_deg, kin.upper_deg)


def assert_inside_limits(kin: Kinematics, angles_deg: np.ndarray) -> None:
    assert np.all(angles_deg >= kin.lower_deg - 1e-9)
    assert np.all(angles_deg <= kin.upper_deg + 1e-9)


SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
# 20 poses each: every line of kinematics.py and ik_descent.py that 40 reached is reached, the
# restarts included (in each test); HYPOTHESIS_PROFILE=explore draws new ones
PROPERTY = settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@PROPERTY
@given(seed=SEEDS)
def test_arm_tool_position_and_pitch_from_home(arm6, seed):
    target = random_angles(arm6, seed)
    position, pitch = mujoco_site(arm6, "tool", target)
    assume(on_the_table(position))
    home = arm6.robot.pose_vector("home")
    solution = arm6.solve([SiteGoal("tool", tuple(position), pitch)], home)
    assert solution.ok
    reached, reached_pitch = mujoco_site(arm6, "tool", solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM
    assert abs(reached_pitch - pitch) <= ANGLE_DEG
    assert_inside_limits(arm6, solution.angles_deg)


@PROPERTY
@given(seed=SEEDS)
def test_arm_held_joints_stay_as_given(arm6, seed):
    """wrist_roll and gripper held: the solution keeps them exactly, and still reaches."""
    target = random_angles(arm6, seed)
    position, pitch = mujoco_site(arm6, "tool", target)
    assume(on_the_table(position))
    seed_deg = np.array(arm6.robot.pose_vector("ready"), dtype=float)
    held = [name in ("wrist_roll", "gripper") for name in arm6.robot.joint_names]
    seed_deg[held] = target[held]
    solution = arm6.solve([SiteGoal("tool", tuple(position), pitch)], seed_deg, np.invert(held))
    assert solution.ok
    np.testing.assert_array_equal(solution.angles_deg[held], target[held])
    reached, _ = mujoco_site(arm6, "tool", solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM


@pytest.mark.parametrize(
    "target",
    [(-26.43, 80.23, -24.68, -83.32, 52.06, 35.33), (-4.9, 83.8, -48.6, -69.2, 23.8, 43.1)],
)
def test_a_pose_whose_other_branch_a_joint_limit_stops_is_reached_on_its_own(arm6, target):
    """Shoulder far forward, elbow back: from the ready pose every descent, restarts included,
    ended on the elbow's other branch with the wrist at its -100° limit, 1.5 and 6 mm short
    (Hypothesis found the first, a search of ~1,300 table poses the second)."""
    target = np.array(target)
    position, pitch = mujoco_site(arm6, "tool", target)
    seed_deg = np.array(arm6.robot.pose_vector("ready"), dtype=float)
    held = [name in ("wrist_roll", "gripper") for name in arm6.robot.joint_names]
    seed_deg[held] = target[held]
    solution = arm6.solve([SiteGoal("tool", tuple(position), pitch)], seed_deg, np.invert(held))
    assert solution.ok, solution
    reached, _ = mujoco_site(arm6, "tool", solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM
    assert_inside_limits(arm6, solution.angles_deg)


@PROPERTY
@given(seed=SEEDS)
def test_hexapod_all_six_feet_at_once(hexapod, seed):
    target = random_angles(hexapod, seed)
    feet = hexapod.feet()
    goals = [SiteGoal(foot, tuple(mujoco_site(hexapod, foot, target)[0])) for foot in feet]
    solution = hexapod.solve(goals, hexapod.robot.pose_vector("home"))
    assert solution.ok
    for goal in goals:
        reached, _ = mujoco_site(hexapod, goal.site, solution.angles_deg)
        assert np.linalg.norm(reached - goal.position_mm) <= POSITION_MM
    assert_inside_limits(hexapod, solution.angles_deg)


@PROPERTY
@given(seed=SEEDS, hand=st.sampled_from(["left_hand", "right_hand"]))
def test_tonypi_hand_moves_only_its_arm(tonypi, seed, hand):
    target = random_angles(tonypi, seed)
    position, _ = mujoco_site(tonypi, hand, target)
    stand = np.array(tonypi.robot.pose_vector("home"), dtype=float)
    solution = tonypi.solve([SiteGoal(hand, tuple(position))], stand)
    assert solution.ok
    reached, _ = mujoco_site(tonypi, hand, solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM
    side = hand.split("_")[0]
    arm = {f"{side}_shoulder_pitch", f"{side}_shoulder_roll", f"{side}_elbow"}
    for name, before, after in zip(tonypi.robot.joint_names, stand, solution.angles_deg):
        if name not in arm:
            assert after == before, name


@pytest.mark.parametrize("seed_pose", ["home", "ready"])
@pytest.mark.parametrize("far", [(1000.0, 0.0, 150.0), (0.0, 400.0, 250.0)])
def test_unreachable_gives_the_closest_point(arm6, far, seed_pose):
    """A point 1 m out ahead, or 90 mm past the reach to the left: the best the arm can do is
    stretch straight at it from the shoulder axis (inside the limits for both: base_yaw 0 or 90°,
    shoulder 82° or 70° from vertical), which leaves it |target - shoulder| - reach away; the
    solver gets within 1 mm of that, from the arm straight up (a singular pose) or bent, and
    reports the point it got to and that point's true distance."""
    far = np.array(far)
    solution = arm6.solve([SiteGoal("tool", tuple(far))], arm6.robot.pose_vector(seed_pose))
    assert not solution.ok
    shoulder = np.array([0.0, 0.0, 66.0 + 40.0])  # turntable + upper arm pivot (arm6.xml)
    reach = 100 + 95 + 50 + 90  # upper arm, forearm, wrist, hand to the tool site
    best_distance = np.linalg.norm(far - shoulder) - reach
    closest, _ = mujoco_site(arm6, "tool", solution.angles_deg)
    np.testing.assert_allclose(solution.reached[0].position_mm, closest, atol=1e-6)
    assert solution.position_error_mm[0] == pytest.approx(np.linalg.norm(far - closest))
    assert best_distance <= solution.position_error_mm[0] <= best_distance + 1.0
    assert_inside_limits(arm6, solution.angles_deg)


def test_a_tool_pointing_nearly_straight_up_is_reached(arm6):
    """Found by the property test above: the tool 87.5° up near the base axis, the elbow 0.8°
    from its limit, wrist_roll and gripper held. The solver once aimed the tool's heading away
    from the base axis whenever it was within 2.9° of vertical, a pose this target has not."""
    target = np.array([81.79, -27.75, 109.23, -83.97, -56.56, 28.78])
    position, pitch = mujoco_site(arm6, "tool", target)
    seed_deg = np.array(arm6.robot.pose_vector("ready"), dtype=float)
    held = np.array([name in ("wrist_roll", "gripper") for name in arm6.robot.joint_names])
    seed_deg[held] = target[held]
    solution = arm6.solve([SiteGoal("tool", tuple(position), pitch)], seed_deg, ~held)
    reached, reached_pitch = mujoco_site(arm6, "tool", solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM
    assert abs(reached_pitch - pitch) <= ANGLE_DEG
    np.testing.assert_array_equal(solution.angles_deg[held], target[held])


@pytest.mark.parametrize("seed_pose", ["home", "ready"])
def test_a_tool_pointing_straight_up_is_reached(arm6, seed_pose):
    """Shoulder +30°, elbow -60°, wrist +30° point the tool straight up (pitch 90°, no heading
    at all) 2.5 mm off the base axis; from the arm straight up (every pitch joint singular for
    the tool's heading) or bent, the solver reaches it."""
    position, pitch = mujoco_site(arm6, "tool", [0.0, 30.0, -60.0, 30.0, 0.0, 0.0])
    assert pitch == pytest.approx(90.0)
    seed = arm6.robot.pose_vector(seed_pose)
    solution = arm6.solve([SiteGoal("tool", tuple(position), pitch)], seed)
    reached, reached_pitch = mujoco_site(arm6, "tool", solution.angles_deg)
    assert np.linalg.norm(reached - position) <= POSITION_MM
    assert abs(reached_pitch - pitch) <= ANGLE_DEG


def test_the_same_target_always_gives_the_same_angles(arm6):
    goal = SiteGoal("tool", (150.0, 60.0, 30.0), -60.0)
    first = arm6.solve([goal], arm6.robot.pose_vector("home"))
    again = kinematics_of("arm6").solve([goal], arm6.robot.pose_vector("home"))
    np.testing.assert_array_equal(first.angles_deg, again.angles_deg)


def test_world_and_base_frames_of_a_walker(hexapod):
    """The hexapod's base is its torso, standing 85.9 mm up in the world at home."""
    np.testing.assert_allclose(hexapod.world_to_base_mm([10, 20, 85.9]), [10, 20, 0], atol=1e-9)


def test_sites_and_feet_of_the_shipped_models(arm6, hexapod, tonypi):
    assert "tool" in arm6.site_names
    assert hexapod.feet() == ("lf_foot", "lm_foot", "lr_foot", "rf_foot", "rm_foot", "rr_foot")
    assert {"left_hand", "right_hand", "left_sole", "right_sole"} <= set(tonypi.site_names)
    assert arm6.feet() == ()


def test_several_sites_at_once_are_each_where_mujoco_puts_it(hexapod):
    angles = random_angles(hexapod, 7)
    feet = hexapod.feet()
    at_once = hexapod.site_positions_mm(feet, angles)
    for foot, position in zip(feet, at_once):
        np.testing.assert_array_equal(position, hexapod.site_pose(foot, angles).position_mm)
        np.testing.assert_allclose(position, mujoco_site(hexapod, foot, angles)[0], atol=1e-9)
