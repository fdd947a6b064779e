"""choreo.motion.gait: foot positions of body poses and gaits, as geometry (no MuJoCo). The rules
are the ones a walk must obey whatever the numbers: feet on the floor do not move over the floor,
every leg swings once per step in its pattern's order, the walk ends standing, strides add up."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from choreo.motion.gait import (
    PHASES,
    SWING_SAMPLES,
    BodyPose,
    Gait,
    Pattern,
    feet_under_body,
    gait_keyframes,
)
from choreo.preview.stance import support_margin

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
    phases = PHASES[gait.pattern]
    swing = len(SWING_SAMPLES)
    assert len(frames) == gait.steps * phases.slots + phases.overhang == gait.keyframes
    floor = np.array([to_floor(STANCE_FRAME)] + [to_floor(f) for f in frames])  # slot, leg, xyz
    slots = np.arange(1, len(frames) + 1)
    # every slot of every leg checked at once (one numpy call each, not one per slot: 60 gaits)
    for leg, first in enumerate(phases.lift_off):
        lift_offs = np.array([step * phases.slots + first for step in range(gait.steps)])
        after = slots[:, None] - lift_offs[None, :]  # each slot's distance past each lift-off
        swinging = (after > 0) & (after <= swing)
        planted = slots[~swinging.any(axis=1)]  # planted: same floor point, on the floor
        np.testing.assert_allclose(
            floor[planted, leg], floor[planted - 1, leg], atol=1e-9, err_msg=f"leg {leg}"
        )
        np.testing.assert_allclose(  # pytest.approx's tolerance
            floor[planted, leg, 2], STANCE[leg][2], rtol=1e-6, atol=1e-12, err_msg=f"leg {leg}"
        )
        lift_off = lift_offs[swinging.argmax(axis=1)]  # the first it swings from, if any
        tops = slots[swinging.any(axis=1) & (slots == lift_off + swing // 2)]  # the middle sample
        np.testing.assert_allclose(
            floor[tops, leg, 2], STANCE[leg][2] + gait.lift_mm, rtol=1e-6, atol=1e-12,
            err_msg=f"leg {leg}",
        )  # fmt: skip


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


def test_each_pattern_has_its_duty_factor_and_phases():
    """The classic hexapod gaits (Ferrell, "Robust and adaptive locomotion of an autonomous
    hexapod"): tripod and wave swing one group at a time; ripple runs a wave on each side, rear
    to front with its legs 1/3 period apart, the two sides half a period apart."""
    assert [PHASES[p].duty_factor for p in Pattern] == pytest.approx([1 / 2, 2 / 3, 5 / 6])
    lf, lm, lr, rf, rm, rr = PHASES[Pattern.RIPPLE].offsets
    assert (lr, lm, lf) == pytest.approx((0, 1 / 3, 2 / 3))
    assert [(right - left) % 1 for left, right in [(lr, rr), (lm, rm), (lf, rf)]] == (
        pytest.approx([1 / 2] * 3)
    )


CENTRE = np.zeros(2)  # the body's centre, standing for its centre of mass


def feet_down(frames) -> list[list[int]]:
    """Between each keyframe and the next (the stance before the first): the feet on the floor
    all along, i.e. at the planned floor height at both ends (a swing is one run of keyframes)."""
    heights = [STANCE[:, 2]] + [f.feet_mm[:, 2] for f in frames]
    down = [np.isclose(h, STANCE[:, 2]) for h in heights]
    return [np.flatnonzero(a & b).tolist() for a, b in zip(down, down[1:])]


@pytest.mark.parametrize(
    "gait",
    [
        Gait(Pattern.RIPPLE, 4, stride_mm=40),
        Gait(Pattern.RIPPLE, 4, stride_mm=0, sideways_mm=30),
        Gait(Pattern.RIPPLE, 3, stride_mm=0, turn_deg=10),
    ],
)
def test_ripple_swings_overlap_with_four_feet_down_and_the_body_inside_them(gait):
    """One leg per side in the air at a time, the sides half a period apart: at every instant
    two legs swing or one does (the swings overlap by half a swing), never two of one side, so
    four or five feet stand, and the body stays well inside the polygon they make (the support
    polygon; the body's centre stands for its centre of mass)."""
    frames = gait_keyframes(STANCE, gait)
    down = feet_down(frames)
    assert min(len(feet) for feet in down) == 4
    assert any(len(feet) == 5 for feet in down)  # one swing lands while the next is in the air
    for feet in down:
        lifted = set(range(6)) - set(feet)
        assert len(lifted & {0, 1, 2}) <= 1 and len(lifted & {3, 4, 5}) <= 1
    before = [STANCE] + [f.feet_mm for f in frames]
    for index, feet in enumerate(down):
        for planted in before[index][feet], before[index + 1][feet]:
            assert support_margin(planted[:, :2], CENTRE) > 75  # mm, of a body ~300 by 430 mm wide
    # the swings overlap: a leg lifts off while the other side's swing is halfway up
    lf, lm, lr, rf, rm, rr = PHASES[Pattern.RIPPLE].lift_off
    assert 0 < rf - lr < len(SWING_SAMPLES)


def test_every_pattern_keeps_at_least_three_feet_under_the_body():
    for pattern, least in [(Pattern.TRIPOD, 3), (Pattern.RIPPLE, 4), (Pattern.WAVE, 5)]:
        frames = gait_keyframes(STANCE, Gait(pattern, 2, stride_mm=40))
        down = feet_down(frames)
        assert min(len(feet) for feet in down) == least
        before = [STANCE] + [f.feet_mm for f in frames]
        assert min(support_margin(before[i + 1][f][:, :2], CENTRE) for i, f in enumerate(down)) > 75
