"""Posing in the 3D view without a browser: a click on a link picks the joint that turns it and
its ring turns it within its limits; a humanoid's hands and feet have handles solved by the
project's IK; a refused drag says why, and the tab that dragged the handle (a site's, the body's,
a joint's ring) shows it back on the robot once let go, whenever the studio answered the moves;
the robot is framed on load."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor

import mujoco
import numpy as np
import pytest
import viser
from studio_helpers import body_sway_rise, copy_motion, refused, shared_studio, studio_on
from viser._messages import (
    SetOrientationMessage,
    SetPositionMessage,
    TransformControlsDragEndMessage,
    TransformControlsDragStartMessage,
    TransformControlsUpdateMessage,
)

from choreo.robot.kinematics import Kinematics
from choreo.robot.robot_file import load_robot
from choreo.studio.address import Address
from choreo.studio.scene import (
    BODY,
    JOINT,
    RobotView,
    about_x,
    axis_frame,
    quaternion_of,
    rotation_of,
)
from choreo.studio.server import Studio

# tonypi stands at home, then squats.
TONYPI = """\
robot: tonypi
keyframes:
  - pose: home
  - pose: squat
    t: 1.5
"""


# one studio for the module's tests on arm6's wave: a start costs more than their drags
_wave, studio = shared_studio("arm6/wave.yaml", "studio")


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


def test_a_ring_dragged_on_reads_the_same_turn_once_the_robot_shown_is_the_posed_one(studio):
    """A drag's moves all turn the ring from where it stood when the drag began. After the first,
    the robot shown is the posed one, not the simulation, whose joint axes lean a hair: the ring
    is read in the frame it was drawn in, not one a quarter turn round (a drag of -20° took the
    elbow to -105°)."""
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


# --- a drag in one tab, as viser hands it to the studio ------------------------------------------

TAB = 7  # the id of the tab that drags (no page is open: what it would be sent stays queued)


def run_into(future: Future, task) -> None:
    try:
        future.set_result(task())
    except BaseException as error:  # as a thread's future would hold it
        future.set_exception(error)


class RunAtOnce(ThreadPoolExecutor):
    """Runs each task as it is submitted. viser hands a drag's callbacks to threads and then
    forwards the dragged pose to the other tabs; run at once, the studio's answer to a move
    comes before that forward: the order in which a handle put back during a drag lost its
    put-back (the forward, queued after it under the same key, replaced it and is not sent to
    the tab that drags)."""

    def submit(self, fn, /, *args, **kwargs):
        future: Future = Future()
        run_into(future, lambda: fn(*args, **kwargs))
        return future

    def run_held(self) -> None:
        pass


class RunLater(ThreadPoolExecutor):
    """Holds each task until ``run_held``, then runs them in turn: a busy machine's threads
    start a drag's work after the tab let go of the handle."""

    def __init__(self):
        super().__init__(max_workers=1)
        self._held: list[tuple[Future, Callable[[], object]]] = []

    def submit(self, fn, /, *args, **kwargs):
        future: Future = Future()
        self._held.append((future, lambda: fn(*args, **kwargs)))
        return future

    def run_held(self) -> None:
        for future, task in self._held:
            run_into(future, task)


def drag_in_a_tab(studio: Studio, name: str, moves, threads=RunAtOnce) -> None:
    """Drag handle ``name`` in tab ``TAB`` through ``moves`` ((position m, quaternion w x y z)
    each) and let go, through viser's own handlers of the tab's messages, on its event loop,
    the work handed to threads done by ``threads`` (viser's own threads again afterwards: the
    studio may serve another test)."""
    server = studio.server
    loop = server._event_loop
    scene = server.scene
    executor = threads()
    own = scene._thread_executor, loop._default_executor
    scene._thread_executor = executor  # viser's, for plain callbacks
    loop.set_default_executor(executor)

    def handle(handler, message) -> None:
        asyncio.run_coroutine_threadsafe(handler(TAB, message), loop).result()

    try:
        handle(scene._handle_transform_controls_drag_start, TransformControlsDragStartMessage(name))
        for position, wxyz in moves:
            update = TransformControlsUpdateMessage(name, tuple(wxyz), tuple(position))
            handle(scene._handle_transform_controls_updates, update)
        handle(scene._handle_transform_controls_drag_end, TransformControlsDragEndMessage(name))
        executor.run_held()
    finally:
        scene._thread_executor, loop._default_executor = own


def shown_in_the_tab(studio: Studio, name: str, dragged) -> tuple[np.ndarray, np.ndarray]:
    """Where the tab that dragged handle ``name`` to ``dragged`` (position, quaternion) shows
    it once everything queued for it is sent: the last position and orientation viser keeps
    queued for the handle unless that one is not for this tab (then the tab keeps its own)."""
    buffer = studio.server._websock_server.get_message_buffer()
    with buffer.buffer_lock:
        queued = [message for _, message in sorted(buffer.message_from_id.items())]
    shown = []
    for kind, field, own in (
        (SetPositionMessage, "position", dragged[0]),
        (SetOrientationMessage, "wxyz", dragged[1]),
    ):
        last = [m for m in queued if isinstance(m, kind) and m.name == name][-1:]
        sent = last and last[0].excluded_self_client != TAB
        shown.append(np.array(getattr(last[0], field) if sent else own, dtype=float))
    return shown[0], shown[1]


@pytest.mark.parametrize("threads", [RunAtOnce, RunLater])
def test_a_site_handle_dragged_out_of_reach_ends_on_the_site_in_the_tab_that_dragged_it(
    studio, threads
):
    """Whenever the studio's threads answer the moves: during the drag or after it."""
    view = studio.view
    assert view is not None
    name = "/sites/tool"
    start = view.handle_pose("tool")
    reach = (start[0] + np.array([0.0, 0.0, -0.05]), start[1])  # down 5 cm: within reach
    away = (start[0] + np.array([0.0, 0.0, 1.0]), start[1])  # a metre up: out of reach
    drag_in_a_tab(studio, name, [reach, away], threads)
    assert refused(studio).startswith("⛔ refused: tool cannot reach there: ")
    site_m = posed_data(view).site("tool").xpos
    assert np.allclose(site_m, reach[0], atol=0.002)  # the last move that worked
    shown, _ = shown_in_the_tab(studio, name, away)
    assert np.allclose(shown, site_m)


def test_a_ring_turned_past_its_joints_limit_ends_at_the_limit_in_the_tab_that_turned_it(studio):
    view = studio.view
    assert view is not None
    robot = view.robot
    elbow, limits = robot.joint_names.index("elbow"), robot.joint("elbow").limits
    joint = view.model.joint(robot.joints[elbow].mjcf_joint)
    studio.pick_joint(*ray_to_body(view, view.model.body(int(joint.bodyid[0])).name, [0, -1, 0]))
    position, wxyz = view.handle_pose(JOINT)
    # 10° short of the limit (taken), then 20° past it: the elbow stops at the limit
    start = studio._pose()[elbow]
    short, past = (
        quaternion_of(rotation_of(wxyz) @ about_x(np.radians(limits.max_deg + d - start)))
        for d in (-10, 20)
    )
    drag_in_a_tab(studio, JOINT, [(position, short), (position, past)])
    assert studio.said[-1] == (  # type: ignore[attr-defined]
        f"elbow stops at its limit {limits.max_deg:g}° "
        f"(the ring was turned to {limits.max_deg + 20:g}°)"
    )
    assert studio.posing is not None and studio.posing[elbow] == limits.max_deg
    _, shown = shown_in_the_tab(studio, JOINT, (position, past))
    assert view.turned_deg(elbow, shown) == pytest.approx(limits.max_deg, abs=0.05)


def test_a_body_handle_dragged_out_of_reach_ends_on_the_body_in_the_tab_that_dragged_it(tmp_path):
    # body_sway's rise: a walker's body handle (the studio simulates a whole motion it loads)
    with studio_on(tmp_path, "hexapod18/body_sway.yaml", body_sway_rise()) as studio:
        view = studio.view
        assert view is not None
        start = view.handle_pose(BODY)
        drag_in_a_tab(studio, BODY, [(start[0] + np.array([0.0, 0.0, 0.25]), start[1])])
        assert refused(studio).startswith("⛔ refused: the body cannot go there: ")
        shown, _ = shown_in_the_tab(studio, BODY, (start[0] + [0.0, 0.0, 0.25], start[1]))
        assert np.allclose(shown, view.root_pose()[0])
