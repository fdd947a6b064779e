"""choreo.emulator.trace: the wire log read back (when STARTs and STOPs reached the servos), the
servos' paths rebuilt from its move starts, and the spread of the starts within a tick."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection
from choreo.emulator.emulated_servo import StartedMove
from choreo.emulator.trace import WireTrace, executed_units, start_skew_ms


def move(time_s, servo_id, from_units, to_units, duration_s):
    return StartedMove(time_s, servo_id, from_units, to_units, duration_s, Command.MOVE_TIME_WRITE)


def test_a_servo_without_moves_stays_where_it_started():
    times = np.array([0.0, 1.0, 5.0])
    np.testing.assert_array_equal(executed_units([], 1, 500, times), [500, 500, 500])


def test_a_move_is_linear_from_its_start_to_its_target_then_holds():
    moves = [move(1.0, 1, 100, 300, 2.0), move(0.5, 2, 0, 1000, 1.0)]  # servo 2's is not ours
    times = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(executed_units(moves, 1, 100, times), [100, 100, 200, 300, 300])


def test_a_later_move_starts_from_where_the_servo_then_is():
    """The log's from_units is where the servo was when the next move began (cut short)."""
    moves = [move(2.0, 1, 250, 0, 1.0), move(0.0, 1, 0, 1000, 4.0)]  # in any order
    times = np.array([1.0, 2.0, 2.5, 3.0, 9.0])
    np.testing.assert_allclose(executed_units(moves, 1, 0, times), [250, 250, 125, 0, 0])


def test_a_move_of_no_duration_jumps():
    moves = [move(1.0, 1, 0, 700, 0.0)]
    np.testing.assert_allclose(
        executed_units(moves, 1, 0, np.array([0.5, 1.0, 2.0])), [0, 700, 700]
    )


def test_start_skew_is_the_spread_within_a_burst_of_starts():
    def starts(*times_ms):
        return [StartedMove(t / 1000, 1, 0, 0, 0, Command.MOVE_TIME_WRITE) for t in times_ms]

    assert start_skew_ms(starts(0, 0, 0, 100, 100)) == 0.0
    assert start_skew_ms(starts(0, 0.87, 1.74, 100, 100.87)) == pytest.approx(1.74)
    assert start_skew_ms(starts(0, 3, 50), since_s=0.01) == 0.0


def test_a_wire_trace_says_when_each_start_and_the_last_stop_reached_the_servos():
    clock = VirtualClock()
    emulator = BusEmulator((1, 2), clock=clock)
    bus = ServoBus(connection(emulator))
    for at_s in (1.0, 2.0, 3.0):  # three ticks, each staged then started at at_s
        clock.sleep_until(at_s)
        bus.stage_move(1, 300, 100)
        bus.stage_move(2, 700, 100)
        bus.start()
    clock.sleep_until(4.0)
    bus.stop()
    clock.sleep_until(4.1)  # its bytes on the wire
    trace = WireTrace.of(emulator)
    clock.sleep_until(5.0)
    bus.stop()  # after the copy: not in it
    clock.sleep_until(5.1)

    starts = trace.start_times_s(since_s=1.5)  # the one at 1.0 is before
    assert len(starts) == 2  # one time per START, though each began two moves
    assert 2.0 < starts[0] < 2.01 and 3.0 < starts[1] < 3.01  # the START's bytes on the wire
    assert 4.0 < trace.last_stop_s(since_s=0.0) < 4.01
    assert trace.last_stop_s(since_s=4.5) is None
    assert WireTrace.of(emulator).last_stop_s(since_s=4.5) > 5.0
