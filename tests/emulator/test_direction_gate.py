"""The emulated direction lines: a host that turns the line around in the wrong order, or waits
for a late drain, loses the exchange as it would on a Pi."""

from __future__ import annotations

import pytest
from direction_helpers import LATE_DRAINS_S, ListensLate, NoDrain, TurnsOnDrain, gated_bus

from choreo.errors import BusTimeoutError


@pytest.mark.parametrize("wrong", [NoDrain, ListensLate])
def test_a_wrong_toggle_order_loses_the_exchange(wrong):
    bus, emulator, _ = gated_bus(wrong)
    with bus, pytest.raises(BusTimeoutError):
        bus.read_position(2)
    if wrong is NoDrain:
        assert not emulator.log.packets  # the request never reached the servo
    else:
        assert emulator.log.replies  # the servo answered; the host never heard it


@pytest.mark.parametrize("late_s", [s for s in LATE_DRAINS_S if s >= 0.001])
def test_the_emulated_gate_drains_late_like_linux(late_s):
    bus, emulator, _ = gated_bus(TurnsOnDrain, drain_late_s=late_s)
    with bus, pytest.raises(BusTimeoutError):
        bus.read_position(2)
    assert emulator.log.replies  # the servo answered while receive was still off
