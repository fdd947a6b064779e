"""Fitting a servo's figures to its reads: the cost, and what it recovers."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.identify.fit import READ_HALF_UNIT_DEG, assumed_figures, fit_servo, read_miss_deg
from choreo.identify.joint_model import Trial, figures_of, simulate
from choreo.identify.moves import fit_moves
from choreo.preview.actuator import actuator_params
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
UNIT_DEG = 2 * READ_HALF_UNIT_DEG


def test_an_angle_within_half_a_unit_of_its_read_misses_nothing_and_beyond_it_the_excess():
    trial = Trial((), np.array([0.0, 0.1, 0.2]), np.array([0.0, 0.24, 0.48]), 0.0)
    predicted = np.array([[0.1, 0.0], [0.36, 0.24], [0.7, 0.3]])
    # the first candidate is 0.10° beyond the third read's unit, the second 0.06° short of it
    assert read_miss_deg(trial, predicted) == pytest.approx([0.10 / 3, 0.06 / 3])


# The whole fit on the wrist_pitch's own test moves: ~7 s of CPU (measured 2026-11-27, 05:20,
# on a loaded machine). 30 generations instead of 45 leave friction 24-54 % high on such truths.
def test_whole_unit_reads_of_a_light_joint_give_back_its_friction_and_dead_band():
    """The joint model's own motion (at a 1 ms step), read in whole units as the bus reads it:
    the fit finds the figures it moved with. Fitted to the reads' distance instead (the mean
    absolute error), friction came out 25-44 % low and the dead band 0.11-0.17° high on this
    truth and two others: a candidate resting at a unit's middle, where the reads are, cost
    less than the truth resting anywhere in it."""
    j = ARM6.joint_names.index("wrist_pitch")
    load = joint_load(ARM6, "wrist_pitch", [0.0] * 6)
    assumed = assumed_figures(actuator_params(ARM6)[j])
    truth = {
        **assumed,
        "friction_nm": 0.055,
        "deadband_deg": 0.6,
        "backlash_deg": 0.8,
        "response_delay_s": 0.015,
        "kp_nm_rad": 19.0,
    }
    plan = fit_moves(ARM6.joints[j], 0.0)
    read_s = np.arange(0.0, plan.duration_s, 0.0037)
    unread = Trial(plan.commands, read_s, np.zeros(len(read_s)), 0.0)
    moved_deg = simulate(unread, load, figures_of([truth]), dt_s=0.001)[:, 0]
    trial = Trial(plan.commands, read_s, np.round(moved_deg / UNIT_DEG) * UNIT_DEG, 0.0)
    found = fit_servo(trial, load, assumed).figures
    assert found["friction_nm"] == pytest.approx(truth["friction_nm"], rel=0.15)
    assert found["deadband_deg"] == pytest.approx(truth["deadband_deg"], abs=0.1)
    assert found["backlash_deg"] == pytest.approx(truth["backlash_deg"], abs=0.1)
