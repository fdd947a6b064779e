"""The studio's 3D scene: the robot drawn by viser from its MuJoCo model, its joints grouped into
limbs (the timeline's lanes) from the model's body tree."""

from __future__ import annotations

import viser

from choreo.robot.robot_file import load_robot
from choreo.studio.scene import RobotView


def limbs_of(robot_name: str):
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        robot = load_robot(robot_name)
        view = RobotView(server, robot, ())
        return robot, view.limbs()
    finally:
        server.stop()


def test_a_hexapod_has_six_legs_of_three_joints_each_joint_in_one_limb():
    robot, limbs = limbs_of("hexapod18")
    assert len(limbs) == 6 and all(len(joints) == 3 for _, joints in limbs)
    assert sorted(j for _, joints in limbs for j in joints) == list(range(len(robot.joints)))
    for _, joints in limbs:  # one leg's coxa, femur and tibia
        names = {robot.joints[j].name.split("_")[0] for j in joints}
        assert len(names) == 1
