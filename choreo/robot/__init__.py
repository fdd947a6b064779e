"""A robot as choreo knows it: joints by name on servo IDs, limits, poses; read from robot.yaml,
checked against its MuJoCo model, and its named sites solved by inverse kinematics.

- :mod:`~choreo.robot.types`: :class:`Robot`, :class:`Joint` (degrees <-> servo units, limits);
- :mod:`~choreo.robot.robot_file`: :func:`load_robot` reads robot.yaml;
  :mod:`~choreo.robot.joint_entry`, :mod:`~choreo.robot.poses`, :mod:`~choreo.robot.bus_entry`:
  its joints, poses and bus block;
- :mod:`~choreo.robot.lookup`: robots found by name (``models/<name>/robot.yaml``);
- :mod:`~choreo.robot.model_check`: robot.yaml against its MJCF model;
- :mod:`~choreo.robot.kinematics`: IK of named sites (:mod:`~choreo.robot.ik_descent`: its damped
  least squares, on arrays).
"""

from __future__ import annotations

from choreo.robot.robot_file import load_robot
from choreo.robot.types import Joint, JointLimits, Robot

__all__ = ["Joint", "JointLimits", "Robot", "load_robot"]
