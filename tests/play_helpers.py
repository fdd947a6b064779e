"""A robot on an emulated bus in virtual time, as the player's tests drive it."""

from __future__ import annotations

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ServoSpec, connection
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import preflight

MOTIONS = "motions"


class Rig:
    """A robot's servos on an emulated bus in virtual time, standing at ``pose``."""

    def __init__(
        self, motion_path, pose="home", skip_ids=(), echo=False, bus_echo="auto", start_gap_s=0.0
    ):
        self.motion = load_motion(motion_path)
        self.robot = self.motion.robot
        self.clock = VirtualClock()
        angles = self.robot.pose_vector(pose)
        specs = [
            ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
            for j, a in zip(self.robot.joints, angles)
            if j.servo_id not in skip_ids
        ]
        self.emulator = BusEmulator(specs, clock=self.clock, echo=echo, start_gap_s=start_gap_s)
        self.bus = ServoBus(connection(self.emulator, echo=bus_echo))

    def play(self, options=None, on_progress=None, **prepare_args):
        options = PlayOptions() if options is None else options
        self.start, limits = preflight(self.bus, self.robot)
        self.performance = prepare(compile_motion(self.motion, **prepare_args), self.start)
        player = Player(self.bus, self.robot, self.clock, limits, options, on_progress)
        self.report = player.play(self.performance.ticks, self.start)
        player.leave(self.report.outcome)
        return self.report

    def packets(self, command):
        return [p for p in self.emulator.log.packets if p.packet.command == command]
