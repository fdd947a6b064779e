"""A robot's bus, opened for a command or a program: the port asked for, else its settings',
else the robot file's ``bus: port``, else the built-in emulator: an emulated bus with the
robot's own servos standing at its home pose, in real time."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager

from choreo.bus.servo_bus import ServoBus
from choreo.bus.settings import BusSettings
from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator, ServoSpec
from choreo.emulator.backend import connection as emulator_connection
from choreo.robot.poses import HOME_POSE
from choreo.robot.types import Robot


@contextmanager
def robot_bus(
    robot: Robot, port: str | ServoBus | None, settings: BusSettings | None = None
) -> Iterator[ServoBus]:
    """The robot's bus, closed on the way out unless the caller opened it (``port`` is a
    :class:`ServoBus`); see :func:`open_robot_bus` for how the port is chosen."""
    if isinstance(port, ServoBus):
        yield port
        return
    with open_robot_bus(robot, port, settings) as bus:
        yield bus


def open_robot_bus(
    robot: Robot, port: str | None = None, settings: BusSettings | None = None
) -> ServoBus:
    """Open the robot's bus: ``port``, else the ``settings``' port, else the robot file's, else
    the built-in emulator; ``settings`` (timeout, retries, echo, direction) default to the robot
    file's ``bus:`` section. The caller closes it."""
    settings = settings if settings is not None else robot.bus
    if port is not None:
        settings = dataclasses.replace(settings, port=port)
    if settings.port is not None:
        return ServoBus.from_settings(settings)
    return ServoBus.from_settings(settings, emulated=emulator_connection(built_in_emulator(robot)))


def built_in_emulator(robot: Robot) -> BusEmulator:
    """The robot's servos on an emulated bus in real time, standing at its home pose."""
    home = robot.pose_vector(HOME_POSE)
    specs = [
        ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
        for j, a in zip(robot.joints, home)
    ]
    return BusEmulator(specs, clock=RealClock())
