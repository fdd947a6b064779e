"""The keyframe timing rules (choreo.motion.timing): t, after, hold, repeat, speed, the first
keyframe."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from choreo.motion.timing import (
    Timing,
    backward_times,
    estimated_arrivals_s,
    known_arrivals_s,
    played_keyframes,
    wanted_arrival_s,
)


@dataclass(frozen=True)
class Kf:
    t_s: float | None = None
    after_s: float | None = None
    hold_s: float = 0.0
    stop: bool = False


def test_t_counts_from_the_start_after_from_leaving_the_keyframe_before():
    played = played_keyframes([Kf(t_s=0.5), Kf(t_s=2.0, hold_s=1.0), Kf(after_s=0.25)])
    assert [p.timing for p in played] == [Timing.AT, Timing.AT, Timing.AFTER]
    assert estimated_arrivals_s(played).tolist() == [0.5, 2.0, 3.25]


def test_speed_divides_every_time():
    played = played_keyframes([Kf(t_s=1.0), Kf(t_s=3.0, hold_s=1.0), Kf(after_s=2.0)], speed=2.0)
    assert estimated_arrivals_s(played).tolist() == [0.5, 1.5, 3.0]
    assert [p.hold_s for p in played] == [0.0, 0.5, 0.0]


def test_repeat_keeps_the_spacing_of_t_from_each_repetitions_first_keyframe():
    keyframes = [Kf(after_s=1.0), Kf(t_s=2.0), Kf(t_s=4.0, hold_s=0.5)]
    played = played_keyframes(keyframes, repeat=2)
    # the first keyframe: waited for at the start, reached after its `after` on the wrap
    assert [p.timing for p in played] == [Timing.AT, Timing.AT, Timing.AT] + [
        Timing.AFTER,
        Timing.AT,
        Timing.AT,
    ]
    assert [p.anchor for p in played] == [None, None, None, None, 3, 3]
    # 4.5 left, +1 after -> 5.5; then t 2 and 4 are 1 and 3 s after the repetition's first
    assert estimated_arrivals_s(played).tolist() == [1.0, 2.0, 4.0, 5.5, 6.5, 8.5]


def test_untimed_keyframes_take_what_the_move_callback_says():
    played = played_keyframes([Kf(), Kf(hold_s=1.0), Kf(after_s=0.5)], repeat=2)
    assert played[3].timing is Timing.ASAP  # the wrap without an `after`
    assert wanted_arrival_s(played, 1, [0.0]) is None
    arrive = estimated_arrivals_s(played, lambda i: 10.0)
    assert arrive.tolist() == [0.0, 10.0, 11.5, 21.5, 31.5, 33.0]


def test_stretch_shifts_move_later_t_values_of_the_same_repetition():
    played = played_keyframes([Kf(t_s=0.0), Kf(t_s=1.0), Kf(t_s=2.0)])
    shifts = [0.0, 0.3, 0.0]
    assert wanted_arrival_s(played, 2, [0.0, 1.3], shifts) == pytest.approx(2.3)


def test_only_the_very_ends_and_stops_and_holds_rest():
    played = played_keyframes([Kf(), Kf(stop=True), Kf(hold_s=0.1), Kf()], repeat=2)
    assert [p.rests for p in played] == [True, True, True, False, False, True, True, True]


def test_a_t_not_after_the_keyframe_before_is_left_goes_backwards():
    keyframes = [Kf(t_s=1.0, hold_s=0.5), Kf(t_s=1.5), Kf(after_s=1.0), Kf(t_s=2.4), Kf(t_s=3.0)]
    # 1.5 is when the first is left (t must be later); the third arrives at 2.5
    backward = backward_times(played_keyframes(keyframes))
    assert [(b.index, b.t_s, b.earliest_leave_s) for b in backward] == [
        (1, 1.5, 1.5),
        (3, 2.4, 2.5),
    ]
    assert backward_times(played_keyframes([])) == []


def test_known_arrivals_are_what_t_and_after_fix_without_planning():
    keyframes = [Kf(t_s=1.0), Kf(), Kf(after_s=0.5), Kf(t_s=3.0, hold_s=0.5), Kf(after_s=1.0)]
    played = played_keyframes(keyframes, speed=2.0)
    # the untimed keyframe and the `after` counting from it are unknown; t is known again
    assert known_arrivals_s(played) == [0.5, None, None, 1.5, 2.25]


def test_known_arrivals_of_repetitions_count_from_their_first_keyframe():
    played = played_keyframes([Kf(after_s=1.0), Kf(t_s=2.0)], repeat=2)
    assert known_arrivals_s(played) == [1.0, 2.0, 3.0, 4.0]
    untimed_wrap = played_keyframes([Kf(), Kf(t_s=2.0)], repeat=2)
    assert known_arrivals_s(untimed_wrap) == [0.0, 2.0, None, None]
