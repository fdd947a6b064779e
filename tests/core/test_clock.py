"""choreo.core.clock: the virtual clock moves only when slept on or advanced, never back, and
exactly under threads; the real clock wakes no earlier than asked."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from choreo.core.clock import RealClock, VirtualClock
from choreo.errors import OptionError


def test_a_virtual_clock_stands_still_until_slept_on():
    clock = VirtualClock(start_s=12.5)
    assert clock.now() == clock.now() == 12.5
    clock.sleep_until(13.0)
    assert clock.now() == 13.0


def test_sleeping_until_a_past_deadline_does_not_turn_the_clock_back():
    clock = VirtualClock()
    clock.sleep_until(2.0)
    clock.sleep_until(1.0)
    assert clock.now() == 2.0


def test_advance_adds_and_refuses_to_go_back():
    clock = VirtualClock()
    clock.advance(0.25)
    clock.advance(0.0)
    assert clock.now() == 0.25
    with pytest.raises(OptionError, match="dt_s must be a number >= 0, got -0.1"):
        clock.advance(-0.1)
    assert clock.now() == 0.25


def test_advances_from_many_threads_all_count():
    """The emulator's pty thread and the player share one clock: no advance may be lost."""
    clock = VirtualClock()

    def advance_a_thousand_times():
        for _ in range(1000):
            clock.advance(1.0)

    threads = [threading.Thread(target=advance_a_thousand_times) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert clock.now() == 4000.0  # whole seconds: exact in floating point


def test_the_real_clock_wakes_no_earlier_than_the_deadline_and_never_goes_back():
    clock = RealClock()
    before = clock.now()
    deadline = before + 0.003  # inside the spin: the last part is spun, not slept
    clock.sleep_until(deadline)
    assert clock.now() >= deadline
    later = before + 0.02  # beyond the spin: slept, then spun
    clock.sleep_until(later)
    assert clock.now() >= later >= before
    clock.sleep_until(before)  # a deadline already passed
    assert clock.now() >= later


@pytest.mark.parametrize("clock", [VirtualClock(5.0), RealClock()], ids=["virtual", "real"])
@pytest.mark.parametrize("deadline", [float("nan"), float("inf"), "1.0", None])
def test_a_deadline_no_clock_reaches_is_refused_naming_it(clock, deadline):
    before = clock.now()
    with pytest.raises(OptionError) as refused:
        clock.sleep_until(deadline)
    assert refused.value.option == "deadline_s"
    assert isinstance(clock, RealClock) or clock.now() == before


def test_deadlines_of_every_real_kind_are_waited_for():
    clock = VirtualClock()
    clock.sleep_until(2)
    clock.sleep_until(np.float64(3.5))
    clock.sleep_until(np.int64(4))
    clock.sleep_until(-float("inf"))  # long past: at once
    assert clock.now() == 4.0


def test_an_advance_past_any_time_a_float_tells_is_refused_and_the_clock_stays():
    clock = VirtualClock(1e308)
    with pytest.raises(OptionError) as refused:
        clock.advance(1e308)
    assert refused.value.option == "dt_s"
    assert clock.now() == 1e308
