"""What the simulation measured against what the motion asked, and the one way a bare rollout or
anything else given where a simulated motion belongs is taken or refused."""

from __future__ import annotations

import pytest

from choreo.errors import OptionError
from choreo.preview import simulate
from choreo.preview.simulated import SimulatedMotion, rollout_of, simulated_of


def test_a_bare_rollout_is_measured_for_what_needs_no_motion(arm3):
    rollout = simulate(arm3, [], [0, 0, 0])
    simulated = simulated_of(rollout)
    assert isinstance(simulated, SimulatedMotion) and simulated.rollout is rollout
    assert simulated.travel is None  # a fixed arm goes nowhere
    assert simulated.walk is None and simulated.gaits == () and simulated.site_reach == ()
    assert rollout_of(simulated) is rollout and rollout_of(rollout) is rollout


@pytest.mark.parametrize("given", [None, "rollout.json", 3])
def test_anything_else_is_refused_naming_both_kinds(given):
    with pytest.raises(OptionError) as refused:
        simulated_of(given, "simulated")
    assert refused.value.option == "simulated"
    assert "a SimulatedMotion (from simulate_motion) or a Rollout (from simulate)" in str(
        refused.value
    )
