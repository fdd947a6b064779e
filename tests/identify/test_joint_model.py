"""The servo on its joint, simulated for many candidates at once."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.identify.fit import assumed_figures
from choreo.identify.joint_model import SentMove, Trial, figures_of, simulate
from choreo.preview.actuator import actuator_params
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
YAW = actuator_params(ARM6)[0]
LOAD = joint_load(ARM6, "base_yaw", [0.0] * 6)  # turning about the vertical: no gravity


def trial(*commands: SentMove, until_s: float = 1.0) -> Trial:
    reads = np.arange(0.0, until_s, 0.002)
    return Trial(tuple(commands), reads, np.zeros(len(reads)), 0.0)


def candidates(**changes: float) -> dict[str, np.ndarray]:
    figures = assumed_figures(YAW)
    return figures_of([figures, {**figures, **changes}])


def test_a_step_asked_at_once_runs_no_faster_than_the_servo_and_a_slower_servo_is_slower():
    step = trial(SentMove(0.0, 60.0, 0.0), until_s=0.8)
    read = simulate(step, LOAD, candidates(no_load_speed_deg_s=YAW.no_load_speed_deg_s / 2))
    halfway_s = [step.read_s[np.argmax(read[:, c] > 30.0)] for c in range(2)]
    assert halfway_s[0] >= 30.0 / YAW.no_load_speed_deg_s  # 80 ms at full speed from the start
    assert halfway_s[1] > 1.7 * halfway_s[0]
    assert read[-1] == pytest.approx([60.0, 60.0], abs=0.5)


def test_a_response_delay_starts_the_move_that_much_later():
    step = trial(SentMove(0.0, 10.0, 0.2), until_s=0.4)
    read = simulate(step, LOAD, candidates(response_delay_s=0.05))
    moving = np.abs(read) > 0.05
    first = [step.read_s[np.argmax(moving[:, c])] for c in range(2)]
    assert first[1] - first[0] == pytest.approx(0.05, abs=0.008)


def test_gear_play_swallows_a_reversal_smaller_than_itself():
    moves = trial(SentMove(0.0, 10.0, 0.3), SentMove(0.6, 8.5, 0.2), until_s=1.2)
    read = simulate(moves, LOAD, candidates(backlash_deg=2.0, deadband_deg=0.0))
    before = read[np.searchsorted(moves.read_s, 0.55)]
    after = read[-1]
    assert before[0] - after[0] > 1.0  # 0.5° of play: it comes back most of the way
    assert before[1] - after[1] == pytest.approx(0.0, abs=0.05)  # 2°: it does not move


def test_gravity_makes_a_loaded_joint_sag_by_its_torque_over_the_gain():
    shoulder = actuator_params(ARM6)[1]
    load = joint_load(ARM6, "shoulder", [0.0] * 6)
    hold = Trial((SentMove(0.0, 60.0, 0.5),), np.arange(0.0, 2.0, 0.002), np.zeros(1000), 0.0)
    figures = assumed_figures(shoulder)
    read = simulate(
        hold, load, figures_of([figures, {**figures, "kp_nm_rad": figures["kp_nm_rad"] / 2}])
    )
    sag = read[-1] - 60.0
    gravity = float(load.gravity_at(np.radians([read[-1, 0]]))[0])
    assert gravity > 0.1  # the arm leans forward, gravity pulls it on
    assert sag[1] > 1.8 * sag[0] > 0
