"""Posing in the 3D view without a browser: a click on a link picks the joint that turns it and
its ring turns it within its limits; a humanoid's hands and feet have handles solved by the
project's IK; a refused drag puts its handle back and says why; the robot is framed on load."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import viser
from studio_helpers import copy_motion, studio_on

from choreo.robot.kinematics import Kinematics
from choreo.robot.robot_file import load_robot
from choreo.studio.address import Address
from choreo.studio.scene import JOINT, RobotView, about_x, axis_frame, quaternion_of, rotation_of
from choreo.studio.server import Studio

# tonypi stands at home, then squats.
TONYPI = """\
robot: tonypi
keyframes:
  - pose: home
  - pose: squat
    t: 1.5
"""


def posed_data(view: RobotView) -> mujoco.MjData:
    """The view's model at the state it last showed."""
    data = mujoco.MjData(view.model)
    data.qpos[:] = view.qpos
    mujoco.mj_kinematics(view.model, data)
    return data


def ray_to_body(view: RobotView, body: str, side: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A ray from 1 m away along ``side`` to the centre of ``body``'s first geom."""
    data = posed_data(view)
    body_id = view.model.body(body).id
    geom = next(g for g in range(view.model.ngeom) if view.model.geom_bodyid[g] == body_id)
    target = np.array(data.geom_xpos[geom])
    origin = target + side
    return origin, target - origin


def test_a_click_on_a_link_picks_its_joint_and_its_ring_turns_it_within_its_limits(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append)
    studio.start()
    try:
        view = studio.view
        assert view is not None
        robot = view.robot
        elbow = robot.joint_names.index("elbow")
        elbow_body = view.model.jnt_bodyid[view.model.joint(robot.joints[elbow].mjcf_joint).id]
        body = view.model.body(elbow_body).name
        studio.pick_joint(*ray_to_body(view, body, np.array([0.0, -1.0, 0.0])))
        assert (
            said[-1]
            == f"turning elbow: drag its ring (within {robot.joint('elbow').limits.range_text})"
        )
        position, wxyz = view.handle_pose(JOINT)
        anchor = posed_data(view).xanchor[view.model.joint(robot.joints[elbow].mjcf_joint).id]
        assert np.allclose(position, anchor)
        assert view.turned_deg(elbow, wxyz) == pytest.approx(studio._pose()[elbow], abs=0.01)

        # the ring turned 25° about its own x axis (the joint's axis): the elbow 25° further
        before = studio._pose()
        turned = quaternion_of(rotation_of(wxyz) @ about_x(np.radians(25.0)))
        studio.turn_joint("elbow", turned)
        assert studio.posing is not None
        assert studio.posing[elbow] == pytest.approx(before[elbow] + 25.0, abs=0.1)
        others = [i for i in range(len(before)) if i != elbow]
        assert np.allclose(studio.posing[others], before[others])

        # turned 10° past its upper limit: the elbow stops at it, says so, and the ring goes
        # back onto the elbow; the other joints stay
        limits = robot.joint("elbow").limits
        posed = studio.posing.copy()
        beyond = limits.max_deg + 10 - float(posed[elbow])
        studio.turn_joint("elbow", quaternion_of(rotation_of(turned) @ about_x(np.radians(beyond))))
        assert said[-1] == (
            f"elbow stops at its limit {limits.max_deg:g}° "
            f"(the ring was turned to {limits.max_deg + 10:g}°)"
        )
        assert studio.posing[elbow] == limits.max_deg
        assert np.array_equal(studio.posing[others], posed[others])
        _, back = view.handle_pose(JOINT)
        assert view.turned_deg(elbow, back) == pytest.approx(limits.max_deg, abs=0.01)

        # on to 190°, which the ring reads as -170°: still the upper limit, the one the elbow
        # stands at, never a jump across its range to the lower
        around = quaternion_of(rotation_of(back) @ about_x(np.radians(190 - limits.max_deg)))
        studio.turn_joint("elbow", around)
        assert studio.posing[elbow] == limits.max_deg

        # a click on the floor: no ring
        studio.pick_joint(np.array([0.5, 0.5, 1.0]), np.array([0.0, 0.0, -1.0]))
        with pytest.raises(KeyError):
            view.handle_pose(JOINT)
    finally:
        studio.close()


def test_a_ring_dragged_on_reads_the_same_turn_once_the_robot_shown_is_the_posed_one(tmp_path):
    """A drag's moves all turn the ring from where it stood when the drag began. After the first,
    the robot shown is the posed one, not the simulation, whose joint axes lean a hair: the ring
    is read in the frame it was drawn in, not one a quarter turn round (a drag of -20° took the
    elbow to -105°)."""
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        view = studio.view
        assert view is not None
        elbow = view.robot.joint_names.index("elbow")
        joint = view.model.joint(view.robot.joints[elbow].mjcf_joint)
        studio.scrub(5.2)  # after the last keyframe: the simulated arm settles at home
        body = view.model.body(int(joint.bodyid[0])).name
        studio.pick_joint(*ray_to_body(view, body, np.array([0.0, -1.0, 0.0])))
        shown_deg = float(np.degrees(view.qpos[joint.qposadr[0]]))
        _, start = view.handle_pose(JOINT)
        for turn_deg in (-5.0, -10.0, -20.0):
            turned = quaternion_of(rotation_of(start) @ about_x(np.radians(turn_deg)))
            studio.turn_joint("elbow", turned)
            assert studio.posing is not None
            # within the lean of the links above: posed, they leave the simulation's angles
            # (a few tenths of a degree off the plan's) for the plan's
            assert studio.posing[elbow] == pytest.approx(shown_deg + turn_deg, abs=0.5)


def test_the_ring_of_a_joint_reads_its_angle_whatever_way_its_axis_points():
    for axis in ([0, 0, 1], [0, -1, 0], [0.3, 0.4, -0.5]):
        frame = axis_frame(axis)
        assert np.allclose(frame[:, 0], np.array(axis) / np.linalg.norm(axis))
        assert np.allclose(frame.T @ frame, np.eye(3))
        assert np.linalg.det(frame) == pytest.approx(1.0)


def test_a_humanoid_has_a_handle_per_limb_solved_by_ik_and_a_reach_too_far_snaps_back(tmp_path):
    path = tmp_path / "squat.yaml"
    path.write_text(TONYPI)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append)
    studio.start()
    try:
        view = studio.view
        assert view is not None
        assert sorted(view.limb_sites()) == ["left_hand", "left_sole", "right_hand", "right_sole"]
        kinematics = Kinematics(load_robot("tonypi"))
        robot = view.robot
        studio.scrub(0.0)
        start = studio._pose()
        hand_m, _ = view.handle_pose("left_hand")
        base_m, base_rotation = view.body_frame(kinematics.base_body)
        target_m = hand_m + base_rotation @ np.array([0.02, 0.0, 0.03])  # 2 cm on, 3 cm up
        studio.drag_site("left_hand", target_m)
        assert studio.posing is not None
        reached = kinematics.site_pose("left_hand", studio.posing).position_mm
        assert np.allclose(reached, base_rotation.T @ (target_m - base_m) * 1000, atol=1.0)
        moved = {n for n, a, b in zip(robot.joint_names, start, studio.posing) if abs(a - b) > 1e-6}
        assert moved and moved <= {"left_shoulder_pitch", "left_shoulder_roll", "left_elbow"}

        posed = studio.posing.copy()
        studio.drag_site("left_sole", target_m + np.array([0.0, 0.0, 1.0]))  # a metre up
        assert said[-1].startswith("⛔ refused: left_sole cannot reach there: the nearest pose is ")
        assert np.array_equal(studio.posing, posed)
        sole_m, _ = view.handle_pose("left_sole")
        data = posed_data(view)
        assert np.allclose(sole_m, data.site("left_sole").xpos)

        studio.scrub(2.0)  # after the squat: the hand keyframe written as sites:, and it plans
        bent = studio._pose()
        bent[robot.joint_names.index("left_elbow")] -= 10  # where the hand would be then
        base_m, base_rotation = view.body_frame(kinematics.base_body)
        there_mm = kinematics.site_pose("left_hand", bent).position_mm
        studio.drag_site("left_hand", base_m + base_rotation @ there_mm / 1000)
        studio.add_keyframe()
        assert not [line for line in said if "nothing written" in line]
        assert path.read_text().startswith(TONYPI + "  - sites: {left_hand: {at: [")
    finally:
        studio.close()


def projected_box(view: RobotView, camera, aspect: float) -> tuple[np.ndarray, np.ndarray]:
    """The robot's box as a camera with ``camera``'s place and vertical field of view sees it,
    +z up: the lowest and highest corners on screen, each -1..1 from edge to edge."""
    low, high = view.robot_box()
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    position, look_at = np.array(camera.position), np.array(camera.look_at)
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = corners - position
    depth = relative @ forward
    assert (depth > 0).all()  # in front of the camera
    half = np.tan(camera.fov / 2)
    screen = np.column_stack(
        [relative @ right / (depth * half * aspect), relative @ up / (depth * half)]
    )
    return screen.min(axis=0), screen.max(axis=0)


@pytest.mark.parametrize("robot_name", ["arm6", "hexapod18", "tonypi"])
def test_every_robot_is_framed_on_load_filling_a_third_of_the_view_or_more(robot_name):
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = RobotView(server, load_robot(robot_name), ())
        for aspect in (900 / 640, 16 / 9):  # the browser tests' window, a wide screen
            low, high = projected_box(view, server.initial_camera, aspect)
            assert (low >= -1).all() and (high <= 1).all()  # all of it in view
            assert (high[1] - low[1]) / 2 >= 1 / 3  # at least a third of its height
    finally:
        server.stop()
