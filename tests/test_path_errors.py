"""choreo.play.path_errors: how far the emulated servos went from the plan, over what was played."""

from __future__ import annotations

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
    from choreo.play.player import Outcome, Player, PlayOptions, preflight

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
