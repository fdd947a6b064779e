"""choreo.play.path_errors: how far the emulated servos went from the plan, over what was played."""

from __future__ import annotations

import pytest
from cli_helpers import REPO

from choreo.emulator import connection


def test_after_a_stop_the_path_error_covers_only_the_part_played():
    from choreo.bus.servo_bus import ServoBus
    from choreo.core.clock import VirtualClock
    from choreo.emulator import BusEmulator
    from choreo.motion.motion_file import load_motion
    from choreo.plan.performance import prepare
    from choreo.plan.pipeline import compile_motion
    from choreo.play.path_errors import measured_path_errors
    from choreo.play.play_options import PlayOptions
    from choreo.play.player import Player
    from choreo.play.preflight import preflight
    from choreo.play.report import Outcome

    def play(stop_at_tick: int | None):
        motion = load_motion(REPO / "motions" / "arm6" / "dance.yaml")
        robot, clock = motion.robot, VirtualClock()
        from emulated import home_specs

        emulator = BusEmulator(home_specs(robot), clock=clock)
        bus = ServoBus(connection(emulator))
        start, limits = preflight(bus, robot)
        performance = prepare(compile_motion(motion), start)

        def ctrl_c(progress):
            if progress.tick == stop_at_tick:
                raise KeyboardInterrupt

        player = Player(bus, robot, clock, limits, PlayOptions(), ctrl_c)
        report = player.play(performance.ticks, start)
        return report, measured_path_errors(emulator.log.moves, robot, performance, report, start)

    completed, whole = play(None)
    stopped, part = play(20)
    assert completed.outcome is Outcome.COMPLETED and stopped.outcome is Outcome.INTERRUPTED
    # what was played follows the plan as closely as a whole run does (not tens of degrees off)
    assert max(part) <= max(whole) + 0.5, (part, whole)


def test_a_servo_on_the_plan_has_no_error_and_one_off_it_has_the_distance_in_degrees():
    """0.24° per unit (servo-models.md): a servo 10 units short of a planned move is 2.4° off."""
    import numpy as np

    from choreo.bus.protocol import Command
    from choreo.emulator.emulated_servo import StartedMove
    from choreo.play.path_errors import path_errors_deg
    from choreo.robot.robot_file import load_robot

    robot = load_robot("arm6")
    home = [j.to_units(a) for j, a in zip(robot.joints, robot.pose_vector("home"))]
    target = list(home)
    target[1] += 100  # the second joint's servo, 24° away
    shoulder = robot.joints[1].servo_id
    moves = [StartedMove(10.0, shoulder, home[1], target[1] - 10, 1.0, Command.MOVE_TIME_WRITE)]
    times = np.linspace(0.0, 2.0, 201)
    fraction = np.clip(times, 0.0, 1.0)[:, None]
    planned_units = np.asarray(home) + (np.asarray(target) - np.asarray(home)) * fraction
    errors = path_errors_deg(moves, robot, home, 10.0, times, robot.to_deg(planned_units))
    assert errors[1] == pytest.approx(2.4)
    assert [e for i, e in enumerate(errors) if i != 1] == [0.0] * 5
