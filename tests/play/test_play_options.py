"""choreo.play.play_options: how a motion is played, each argument checked as it is given."""

from __future__ import annotations

import dataclasses

import pytest

from choreo.errors import OptionError
from choreo.plan.pipeline import PlanOptions
from choreo.play.play_options import ExitMode, PlayOptions


def test_the_planning_fields_are_the_plan_options_and_default_as_they_do():
    assert PlayOptions().plan == PlanOptions()
    options = PlayOptions(speed=2, stretch=True, tolerance_deg=1.5)
    assert options.plan == PlanOptions(speed=2, stretch=True, tolerance_deg=1.5)
    assert dataclasses.replace(options, speed=None).plan.speed is None


@pytest.mark.parametrize(
    "arguments, option",
    [
        (dict(speed=0), "speed"),
        (dict(stretch="no"), "stretch"),
        (dict(tolerance_deg=0), "tolerance_deg"),
        (dict(loop=0), "loop"),
        (dict(audio=1), "audio"),
        (dict(lead_s=-0.1), "lead_s"),
    ],
)
def test_a_bad_argument_is_refused_naming_it(arguments, option):
    with pytest.raises(OptionError) as refused:
        PlayOptions(**arguments)
    assert refused.value.option == option


def test_an_exit_mode_may_be_given_by_its_name():
    assert PlayOptions(exit_mode="unload").exit_mode is ExitMode.UNLOAD
