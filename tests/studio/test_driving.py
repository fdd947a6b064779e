"""Driving the robot from the studio: once asked, scrubbing moves the live robot within the approach
limits, and Stop stops it."""

from __future__ import annotations

import numpy as np
from emulated import home_specs, wait_for
from studio_helpers import copy_motion

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial
from choreo.robot.robot_file import load_robot
from choreo.studio.address import Address
from choreo.studio.live import LiveRobot
from choreo.studio.server import Studio


def test_scrubbing_drives_the_live_robot_once_asked_and_stop_stops_it(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    robot = load_robot("arm6")
    clock = VirtualClock()
    emulator = BusEmulator(home_specs(robot), clock=clock)
    said: list[str] = []
    live = LiveRobot(ServoBus(SimSerial.from_emulator(emulator)), robot, clock, said.append)
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append, live=live)
    studio.start()
    try:
        studio.scrub(2.0)  # not driving yet: the robot stays at home
        assert not [m for m in emulator.log.moves if m.command is not Command.MOVE_STOP]
        studio.drive(True)
        plan = studio.session.plan
        assert plan is not None
        wanted = plan.planned_deg(2.0)  # keyframe 3: base_yaw 30, shoulder 30, elbow 40
        wait_for(lambda: np.allclose(live.pose_deg, wanted), "the robot at the scrubbed pose")
        studio.stop_robot()
        wait_for(lambda: "stopped the servos" in said, "the stop")
        moves = len(emulator.log.moves)
        studio.scrub(3.0)  # no longer driving
        assert len(emulator.log.moves) == moves and not studio.driving
        # requests a page should not make: refused with a note, nothing changes
        studio.scrub(99.0)
        studio.set_speed("1e9")
        studio.move_joint("gripper", "lots")
        assert said[-3:] == [
            "⛔ refused: t 99 s is outside the timeline 0.00..3.50 s",
            "⛔ refused: speed '1e9' is not one of 0.25, 0.5, 1, 2",
            "⛔ refused: joint 'gripper' = 'lots' is not a joint and an angle",
        ]
        assert studio.time_s == 3.0 and studio.speed == 1.0
    finally:
        studio.close()
