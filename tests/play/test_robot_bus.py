"""choreo.play.robot_bus: the port asked for, else the settings', else the robot file's, else
the built-in emulator with the robot's own servos at home."""

from __future__ import annotations

import pytest

from choreo.bus.servo_bus import ServoBus
from choreo.bus.settings import BusSettings
from choreo.play import robot_bus as robot_bus_module
from choreo.play.robot_bus import built_in_emulator, open_robot_bus, robot_bus
from choreo.robot.robot_file import load_robot

VIRTUAL = "sim://?ids=1-6&clock=virtual"


@pytest.fixture
def arm():
    return load_robot("arm6")


def test_without_a_port_anywhere_the_robots_servos_stand_at_home(arm, monkeypatch):
    made = []

    def recorded(robot):
        made.append(built_in_emulator(robot))
        return made[-1]

    monkeypatch.setattr(robot_bus_module, "built_in_emulator", recorded)
    with open_robot_bus(arm) as bus:
        assert bus.emulator is made[0]
        at = [bus.read_position(j.servo_id) for j in arm.joints]
    home = [round(j.to_units(a)) for j, a in zip(arm.joints, arm.pose_vector("home"))]
    assert at == home


def test_a_port_given_wins_over_the_settings_and_keeps_their_other_fields(arm):
    settings = BusSettings(port="/dev/does-not-exist", retries=4)
    with open_robot_bus(arm, VIRTUAL, settings) as bus:
        assert bus.name == VIRTUAL
        assert bus.retries == 4


def test_a_bus_the_caller_opened_is_used_and_left_open(arm):
    with ServoBus(VIRTUAL) as opened:
        with robot_bus(arm, opened) as bus:
            assert bus is opened
        assert opened.ping(1)  # still open
