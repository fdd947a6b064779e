"""choreo.motion.gait: foot positions of body poses and gaits, as geometry (no MuJoCo). The rules
are the ones a walk must obey whatever the numbers: feet on the floor do not move over the floor,
every leg swings once per step in its pattern's order, the walk ends standing, strides add up."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from choreo.motion.gait import (
    GROUPS,
    SWING_SAMPLES,
    BodyPose,
    Gait,
    Pattern,
    feet_under_body,
    gait_keyframes,
)

# the hexapod's feet at home (mm, body frame), left front/middle/rear then right
STANCE = np.array(
    [
        [187.8, 157.8, -75.9],
        [0.0, 215.3, -75.9],
        [-187.8, 157.8, -75.9],
        [187.8, -157.8, -75.9],
        [0.0, -215.3, -75.9],
        [-187.8, -157.8, -75.9],
    ]
)


def to_floor(frame) -> np.ndarray:
    x, y, heading_deg = frame.body_mm_deg
    c, s = np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return frame.feet_mm @ rot.T + [x, y, 0]


GAITS = st.builds(
    Gait,
    pattern=st.sampled_from(list(Pattern)),
    steps=st.integers(1, 5),
    stride_mm=st.floats(-60, 60),
    sideways_mm=st.floats(-40, 40),
    turn_deg=st.floats(-20, 20),
    lift_mm=st.floats(5, 40),
)


@settings(max_examples=60, deadline=None)
@given(gait=GAITS)
def test_feet_on_the_floor_stay_put_and_swings_follow_the_pattern(gait):
    frames = gait_keyframes(STANCE, gait)
    groups = GROUPS[gait.pattern]
    assert len(frames) == gait.steps * len(groups) * len(SWING_SAMPLES)
    floor = [to_floor(STANCE_FRAME)] + [to_floor(f) for f in frames]
    for index in range(len(frames)):
        group = groups[(index // len(SWING_SAMPLES)) % len(groups)]
        for leg in range(6):
            if leg not in group:  # planted: same floor point, on the floor
                np.testing.assert_allclose(floor[index + 1][leg], floor[index][leg], atol=1e-9)
                assert floor[index + 1][leg][2] == pytest.approx(STANCE[leg][2])
        top = frames[index - index % len(SWING_SAMPLES) + 1]  # the middle sample: the top
        for leg in group:
            assert to_floor(top)[leg][2] == pytest.approx(STANCE[leg][2] + gait.lift_mm)


STANCE_FRAME = type("Frame", (), {"feet_mm": STANCE, "body_mm_deg": (0.0, 0.0, 0.0)})()


@settings(max_examples=60, deadline=None)
@given(gait=GAITS)
def test_a_gait_ends_standing_steps_strides_further_on(gait):
    frames = gait_keyframes(STANCE, gait)
    np.testing.assert_allclose(frames[-1].feet_mm, STANCE, atol=1e-9)
    x, y, heading = frames[-1].body_mm_deg
    assert heading == pytest.approx(gait.steps * gait.turn_deg)
    if gait.turn_deg == 0:
        assert (x, y) == pytest.approx((gait.steps * gait.stride_mm, gait.steps * gait.sideways_mm))


def test_six_tripod_steps_of_40_mm_go_240_mm():
    frames = gait_keyframes(STANCE, Gait(Pattern.TRIPOD, 6, stride_mm=40))
    assert frames[-1].body_mm_deg == pytest.approx((240.0, 0.0, 0.0))
    # tripod A (lf, rm, lr) swings first, then B (rf, lm, rr)
    first, second = frames[1], frames[5]  # the tops of the first two swings
    assert [leg for leg in range(6) if first.feet_mm[leg][2] > -75] == [0, 2, 4]
    assert [leg for leg in range(6) if second.feet_mm[leg][2] > -75] == [1, 3, 5]


def test_turning_in_place_keeps_the_body_over_its_start():
    frames = gait_keyframes(STANCE, Gait(Pattern.TRIPOD, 6, stride_mm=0, turn_deg=10))
    for frame in frames:
        assert np.hypot(*frame.body_mm_deg[:2]) < 1e-9
    assert frames[-1].body_mm_deg[2] == pytest.approx(60.0)


def test_body_up_moves_the_feet_down_in_the_body_frame():
    np.testing.assert_allclose(
        feet_under_body(STANCE, BodyPose(z_mm=20)), STANCE - [0, 0, 20], atol=1e-12
    )


def test_body_roll_lifts_the_left_side():
    """Rolled +5° (about the forward x axis), the body's left side rises and its right side
    sinks: the left feet end up further below the body, the right feet closer to it."""
    feet = feet_under_body(STANCE, BodyPose(roll_deg=5))
    left, right = feet[1], feet[4]
    assert left[2] < STANCE[1][2] < right[2]
    # distances between feet never change: they stay planted
    for a in range(6):
        for b in range(6):
            assert np.linalg.norm(feet[a] - feet[b]) == pytest.approx(
                np.linalg.norm(STANCE[a] - STANCE[b])
            )


def test_body_yaw_turns_the_feet_back():
    feet = feet_under_body(STANCE, BodyPose(yaw_deg=90))
    np.testing.assert_allclose(feet[1], [215.3, 0.0, -75.9], atol=1e-9)
