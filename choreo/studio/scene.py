"""The robot in the browser: its MuJoCo scene (floor, props) converted to viser nodes by mjviser,
posed from the simulation, with the plan's pose drawn over it as a ghost skeleton.

The only module of the studio that touches MuJoCo's data (``choreo.preview`` builds the model).
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from choreo.motion.scene import Prop
from choreo.preview.model import free_joint, index_joints, load_model
from choreo.robot.types import Robot
from choreo.studio import require

log = logging.getLogger(__name__)
GHOST_RGB = (40, 120, 255)
GHOST_WIDTH = 4.0
AMBIENT, KEY_LIGHT = 1.2, 2.0  # without the environment map: soft fill, one light from above
HANDLE_SCALE = 0.25  # a site's drag handle, as a share of the model's size
BODY = "/body"  # the body's handle among the sites' (no site is named so)
JOINT = "/joint"  # the picked joint's ring (no site is named so either)
FRAME_FROM = np.array([1.2, -1.6, 0.9])  # the camera looks at the robot from here (front left)
FRAME_FILL = 0.6  # the robot's sphere fills this share of the view's half-height


class RobotView:
    """The robot of one model in the scene; ``show`` poses it."""

    def __init__(self, server, robot: Robot, props: Sequence[Prop]):
        mjviser = require("mjviser")
        self.robot, self.props = robot, tuple(props)
        self.model = load_model(robot, props)
        self._index = index_joints(self.model, robot)
        self._data = mujoco.MjData(self.model)
        self._ghost_data = mujoco.MjData(self.model)
        self._server = server
        self._scene = mjviser.ViserMujocoScene(server, self.model, num_envs=1)
        self._scene.camera_tracking_enabled = False  # the ghost is drawn in world coordinates
        # mjviser lights the scene with an HDR environment map: seconds of work for a browser
        # without a GPU before the first frame. Plain lights instead.
        server.scene.configure_environment_map(hdri=None)
        server.scene.add_light_ambient("/lights/ambient", intensity=AMBIENT)
        server.scene.add_light_directional(
            "/lights/key", intensity=KEY_LIGHT, position=(1.0, -1.5, 3.0)
        )
        self._bones = np.array(
            [(self.model.body_parentid[b], b) for b in range(1, self.model.nbody)]
            if self.model.nbody > 1
            else np.zeros((0, 2), dtype=int)
        )
        self._bones = self._bones[self._bones[:, 0] > 0]  # bodies hanging from the world: none
        self.ghost_visible = True
        self._handles: dict[str, Any] = {}  # site name -> its handle; BODY: the body's
        self._dragging: dict[str, int] = {}  # handle name -> how many tabs drag it now
        # the robot drawn and the handles placed on it: a drag let go places them from viser's
        # event loop's threads while the studio draws from its own
        self._drawing = threading.RLock()
        self._turning: int | None = None  # the robot joint whose ring is shown (JOINT)
        self._joint_ids = [
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, j.mjcf_joint)
            for j in robot.joints
        ]
        root = free_joint(self.model)
        self._root_body = None if root is None else int(self.model.jnt_bodyid[root])
        self._root_qpos = None if root is None else int(self.model.jnt_qposadr[root])
        server.scene.set_up_direction("+z")
        mujoco.mj_kinematics(self.model, self._data)
        self.frame_camera()

    def frame_camera(self, clients: Sequence[Any] = ()) -> None:
        """Look at the robot as it stands from the front left, near enough that it fills about
        two thirds of the view's height: for tabs opened from now on, and ``clients`` now."""
        center, radius = self._robot_sphere()
        camera = self._server.initial_camera
        distance = radius / (FRAME_FILL * np.tan(camera.fov / 2))
        position = center + distance * FRAME_FROM / np.linalg.norm(FRAME_FROM)
        camera.look_at, camera.position = center, position
        for client in clients:
            client.camera.look_at, client.camera.position = center, position

    def _robot_sphere(self) -> tuple[np.ndarray, float]:
        """The centre and radius (m) of a sphere around the robot's box."""
        low, high = self.robot_box()
        return (low + high) / 2, max(float(np.linalg.norm(high - low)) / 2, 0.01)

    def robot_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and highest corners (world, m) of a box around the robot's geoms as last
        posed (not the floor's or the props')."""
        model, data = self.model, self._data
        bodies = self._robot_bodies()
        geoms = [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in bodies]
        if not geoms:
            extent = float(model.stat.extent)
            return np.array(model.stat.center) - extent, np.array(model.stat.center) + extent
        centres = data.geom_xpos[geoms]
        reach = model.geom_rbound[geoms]
        return (centres - reach[:, None]).min(axis=0), (centres + reach[:, None]).max(axis=0)

    def _robot_bodies(self) -> set[int]:
        """The robot's bodies: the tree hanging from the top body of its joints."""
        model = self.model
        tops = set()
        for body in self._bodies_with_joints():
            while int(model.body_parentid[body]) > 0:
                body = int(model.body_parentid[body])
            tops.add(body)
        return {b for b in range(1, model.nbody) if int(model.body_rootid[b]) in tops}

    def limbs(self) -> tuple[tuple[str, tuple[int, ...]], ...]:
        """The robot's joints grouped by limb, in joint order: (the limb's first body, the
        indices of its joints). A limb is a chain of bodies below the last body where the tree
        branches (an arm on its own is one limb; a hexapod has six)."""
        model = self.model
        children: dict[int, list[int]] = {}
        for body in range(1, model.nbody):
            children.setdefault(int(model.body_parentid[body]), []).append(body)
        with_joints = self._bodies_with_joints()

        def branches(body: int) -> int:
            return sum(1 for child in children.get(body, ()) if child in with_joints)

        limbs: dict[str, list[int]] = {}
        for index, joint in enumerate(self.robot.joints):
            joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
            body = int(model.jnt_bodyid[joint_id])
            while True:
                parent = int(model.body_parentid[body])
                if parent <= 0 or parent == self._root_body or branches(parent) > 1:
                    break
                body = parent
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"
            limbs.setdefault(name, []).append(index)
        return tuple((name, tuple(joints)) for name, joints in limbs.items())

    def _bodies_with_joints(self) -> set[int]:
        """Bodies with a robot joint in or below them."""
        model, found = self.model, set()
        for joint in self.robot.joints:
            joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.mjcf_joint)
            body = int(model.jnt_bodyid[joint_id])
            while body > 0 and body not in found:
                found.add(body)
                body = int(model.body_parentid[body])
        return found

    def matches(self, robot: Robot, props: Sequence[Prop]) -> bool:
        """This view still draws ``robot`` with ``props`` (else the scene is rebuilt)."""
        return robot == self.robot and tuple(props) == self.props

    @property
    def qpos(self) -> np.ndarray:
        """The whole state last shown."""
        return np.array(self._data.qpos)

    def qpos_with(
        self, qpos: np.ndarray, angles_deg: np.ndarray, root: tuple | None = None
    ) -> np.ndarray:
        """``qpos`` (the whole state: the body's place too) with the joints at ``angles_deg``
        and a free-floating robot's body at ``root`` (position m, quaternion w x y z) if given."""
        out = np.array(qpos, dtype=float)
        out[self._index.qpos] = np.radians(angles_deg)
        if root is not None and self._root_qpos is not None:
            out[self._root_qpos : self._root_qpos + 7] = np.concatenate(root)
        return out

    def root_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Where a free-floating robot's body is drawn: (position m, quaternion w x y z)."""
        assert self._root_body is not None, "a robot fixed to the world has no body to pose"
        return (
            np.array(self._data.xpos[self._root_body]),
            np.array(self._data.xquat[self._root_body]),
        )

    def body_frame(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Where body ``name`` is drawn: (position m, rotation matrix)."""
        body = self._data.body(name)
        return np.array(body.xpos), np.array(body.xmat).reshape(3, 3)

    def limb_sites(self) -> tuple[str, ...]:
        """One site per limb, the one farthest down it (moved by most of its joints): a
        humanoid's hands and feet. A site no joint moves (on the torso) is none."""
        model = self.model
        chosen = []
        for _, joints in self.limbs():
            limb = {self._joint_ids[j] for j in joints}
            best, most = None, 0
            for site in range(model.nsite):
                moving = self._joints_above(int(model.site_bodyid[site]))
                if moving and moving <= limb and len(moving) > most:
                    best, most = model.site(site).name, len(moving)
            if best:
                chosen.append(best)
        return tuple(chosen)

    def _joints_above(self, body: int) -> set[int]:
        """The robot's joints (MuJoCo ids) that move ``body``: in it and the bodies above it."""
        model, found = self.model, set()
        while body > 0:
            found |= {j for j in self._joint_ids if int(model.jnt_bodyid[j]) == body}
            body = int(model.body_parentid[body])
        return found

    # --- one joint picked and turned ----------------------------------------------------------

    def joint_at(self, origin_m: np.ndarray, direction: np.ndarray) -> int | None:
        """The robot joint (its index) that turns the link a ray from ``origin_m`` along
        ``direction`` meets first; None if the ray meets no link a joint of the robot turns
        (the floor, a prop, a base fixed to the world)."""
        direction = np.asarray(direction, dtype=float)
        length = float(np.linalg.norm(direction))
        if length < 1e-12 or not np.all(np.isfinite(origin_m)):
            return None
        hit = np.zeros(1, dtype=np.int32)
        origin = np.asarray(origin_m, dtype=float)
        if mujoco.mj_ray(self.model, self._data, origin, direction / length, None, 0, -1, hit) < 0:
            return None
        body = int(self.model.geom_bodyid[hit[0]])
        while body > 0:
            joints = [i for i, j in enumerate(self._joint_ids) if self.model.jnt_bodyid[j] == body]
            if joints:
                return joints[0]
            body = int(self.model.body_parentid[body])
        return None

    def add_joint_handle(self, joint: int, on_turn: Callable[[str, np.ndarray], None]) -> None:
        """A ring about joint ``joint``'s axis at its anchor, in place of the last one:
        ``on_turn(joint name, quaternion w x y z)`` as it is dragged (``turned_deg`` reads it)."""
        self.remove_joint_handle()
        name = self.robot.joints[joint].name
        position, wxyz = self._joint_handle_pose(joint)
        handle = self._server.scene.add_transform_controls(
            JOINT,
            scale=float(self.model.stat.extent) * HANDLE_SCALE,
            # the ring about its x axis (the joint's axis) is drawn for the y-z plane: viser's
            # gizmo shows a ring only where both axes of its plane are active
            active_axes=(False, True, True),
            disable_axes=True,
            disable_sliders=True,
            position=position,
            wxyz=wxyz,
        )
        handle.on_update(self._drag_callback(JOINT, lambda _, wxyz: on_turn(name, wxyz)))
        with self._drawing:
            self._handles[JOINT], self._turning = handle, joint

    def remove_joint_handle(self) -> None:
        with self._drawing:
            handle = self._handles.pop(JOINT, None)
            self._turning = None
        if handle is not None:
            handle.remove()

    def turned_deg(self, joint: int, wxyz: npt.ArrayLike) -> float:
        """The angle of joint ``joint`` that its ring turned to ``wxyz`` stands for."""
        turn = self._zero_frame(joint).T @ rotation_of(wxyz)
        return float(np.degrees(np.arctan2(turn[2, 1], turn[1, 1])))

    def _joint_handle_pose(self, joint: int) -> tuple[np.ndarray, np.ndarray]:
        """The ring at the joint's anchor, its x axis on the joint's axis, turned as the joint
        is (so ``turned_deg`` of it is the joint's angle)."""
        joint_id = self._joint_ids[joint]
        angle = float(self._data.qpos[self.model.jnt_qposadr[joint_id]])
        rotation = self._zero_frame(joint) @ about_x(angle)
        return np.array(self._data.xanchor[joint_id]), quaternion_of(rotation)

    def _zero_frame(self, joint: int) -> np.ndarray:
        """Where joint ``joint``'s ring stands at angle 0: its x axis on the joint's axis, its y
        and z fixed to the link above the joint. Made from the axis in the link's own frame, not
        the world's: a frame made from the axis alone turns its y and z a quarter turn when the
        axis leans a hair (a simulated one does, a posed one does not), so a drag's second move
        read 90° off its first."""
        model, data = self.model, self._data
        joint_id = self._joint_ids[joint]
        body = int(model.jnt_bodyid[joint_id])
        frame = data.xmat[body].reshape(3, 3)
        # MuJoCo turns a body by its hinges in order, each from its reference angle (qpos0):
        # undo them back to this one
        for j in reversed(range(joint_id, model.njnt)):
            if model.jnt_bodyid[j] == body and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                address = model.jnt_qposadr[j]
                hinge = axis_frame(model.jnt_axis[j])
                turned = float(data.qpos[address] - model.qpos0[address])
                frame = frame @ hinge @ about_x(-turned) @ hinge.T
        reference = float(model.qpos0[model.jnt_qposadr[joint_id]])
        return frame @ axis_frame(model.jnt_axis[joint_id]) @ about_x(-reference)

    def handle_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Where handle ``name`` (a site, BODY or JOINT) is: (position m, quaternion w x y z)."""
        handle = self._handles[name]
        return np.array(handle.position), np.array(handle.wxyz)

    def show(self, qpos: np.ndarray, ghost_deg: np.ndarray | None) -> None:
        """The robot at ``qpos``; the ghost at the same place with the joints at ``ghost_deg``."""
        with self._drawing:
            self._data.qpos[:] = qpos
            mujoco.mj_kinematics(self.model, self._data)
            self._scene.update_from_mjdata(self._data)
            self._place_handles()
        if ghost_deg is None or not self.ghost_visible or not len(self._bones):
            self._server.scene.remove_by_name("/ghost")
            return
        self._ghost_data.qpos[:] = self.qpos_with(qpos, ghost_deg)
        mujoco.mj_kinematics(self.model, self._ghost_data)
        points = self._ghost_data.xpos[self._bones]  # (bones, 2, 3)
        self._server.scene.add_line_segments(
            "/ghost",
            points=points,
            colors=GHOST_RGB,
            thickness=GHOST_WIDTH,
            thickness_units="screen",
        )

    def add_site_handles(
        self, names: Sequence[str], on_drag: Callable[[str, np.ndarray], None]
    ) -> None:
        """A drag handle at each of the robot's sites; ``on_drag(site, world position m)``."""
        size = float(self.model.stat.extent) * HANDLE_SCALE
        for name in names:
            handle = self._server.scene.add_transform_controls(
                f"/sites/{name}",
                scale=size,
                disable_rotations=True,
                position=np.array(self._data.site(name).xpos),
            )
            handle.on_update(self._drag_callback(name, self._site_drag(name, on_drag)))
            with self._drawing:
                self._handles[name] = handle

    @staticmethod
    def _site_drag(
        name: str, on_drag: Callable[[str, np.ndarray], None]
    ) -> Callable[[np.ndarray, np.ndarray], None]:
        return lambda position, _: on_drag(name, position)

    def add_body_handle(self, on_drag: Callable[[np.ndarray, np.ndarray], None]) -> None:
        """A handle on a free-floating robot's body, to move and turn it:
        ``on_drag(world position m, quaternion w x y z)``."""
        position, wxyz = self.root_pose()
        handle = self._server.scene.add_transform_controls(
            "/body",
            scale=float(self.model.stat.extent) * HANDLE_SCALE,
            position=position,
            wxyz=wxyz,
        )
        handle.on_update(self._drag_callback(BODY, on_drag))
        with self._drawing:
            self._handles[BODY] = handle

    def _drag_callback(self, name: str, on_move: Callable[[np.ndarray, np.ndarray], None]):
        """viser's callback for the drags of handle ``name``: ``on_move(position m, quaternion
        w x y z)`` for each move, in a thread. A handle is not moved while a tab drags it: viser
        forwards each move to the other tabs in a message that replaces a put-back queued just
        before it and is not sent to the tab that drags, which kept a refused pose. Let go, it
        goes where the robot is. Async, so that viser runs it on its event loop in the order the
        tab sent its start, moves and end (a plain one runs in any of its threads, in any order),
        and reads each move's pose before a later message changes it."""

        async def callback(event) -> None:
            if event.phase == "start":
                self._dragging[name] = self._dragging.get(name, 0) + 1
            elif event.phase == "update":
                target = event.target
                in_a_thread(on_move, np.array(target.position), np.array(target.wxyz))
            else:  # "end": let go (or its tab closed)
                self._dragging[name] = max(self._dragging.get(name, 0) - 1, 0)
                in_a_thread(self._place_handles)

        return callback

    def _place_handles(self) -> None:
        """Every handle where the robot shown puts it but those being dragged."""
        with self._drawing:
            for name, handle in self._handles.items():
                if self._dragging.get(name):  # in a tab's hand: placed when let go
                    continue
                if name == BODY:
                    handle.position, handle.wxyz = self.root_pose()
                elif name == JOINT:
                    assert self._turning is not None
                    handle.position, handle.wxyz = self._joint_handle_pose(self._turning)
                else:
                    handle.position = np.array(self._data.site(name).xpos)


def in_a_thread(work: Callable[..., None], *args: Any) -> None:
    """``work(*args)`` in a thread of the running event loop's; a failure is logged (a bug
    must not go unheard, nor stop the page being heard)."""

    def run() -> None:
        try:
            work(*args)
        except Exception:  # noqa: BLE001
            log.exception("a drag's work failed")

    asyncio.get_running_loop().run_in_executor(None, run)


def axis_frame(axis: npt.ArrayLike) -> np.ndarray:
    """A rotation whose x axis is ``axis`` (its y and z fixed by ``axis`` alone)."""
    x = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    least = np.eye(3)[int(np.argmin(np.abs(x)))]  # the world axis farthest from it
    y = np.cross(x, least)
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def about_x(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_of(wxyz: npt.ArrayLike) -> np.ndarray:
    """The rotation matrix of a quaternion (w, x, y, z)."""
    matrix = np.zeros(9)
    mujoco.mju_quat2Mat(matrix, np.asarray(wxyz, dtype=float) / np.linalg.norm(wxyz))
    return matrix.reshape(3, 3)


def quaternion_of(rotation: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) of a rotation matrix."""
    wxyz = np.zeros(4)
    mujoco.mju_mat2Quat(wxyz, np.ascontiguousarray(rotation, dtype=float).reshape(9))
    return wxyz
