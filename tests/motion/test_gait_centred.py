"""Each foot works as far ahead of its neutral spot (where it stands at home) as behind it,
whichever group of the pattern it is in: the swings land under the body's mid-stance pose."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.motion.gait import Gait, Pattern, gait_keyframes

# hexapod18's feet at home (mm, body frame): lf lm lr rf rm rr
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


@pytest.mark.parametrize(
    "pattern, groups", [(Pattern.TRIPOD, 2), (Pattern.RIPPLE, 3), (Pattern.WAVE, 6)]
)
def test_every_foot_stands_centred_on_its_neutral_spot(pattern, groups):
    """A foot stands while the body moves (groups - 1) / groups of a 40 mm stride: in the steps
    between the first and the last, from half that ahead of its neutral spot to half behind
    (tripod: +-10 mm; before, one tripod worked 0..+20 mm and the other -20..0)."""
    frames = gait_keyframes(STANCE, Gait(pattern, 4, 40.0))
    half = 40.0 * (groups - 1) / groups / 2
    for foot in range(6):
        planted = [
            f.feet_mm[foot, 0] - STANCE[foot, 0]
            for f in frames
            if abs(f.feet_mm[foot, 2] - STANCE[foot, 2]) < 1e-6 and 2 <= f.step <= 3
        ]
        assert min(planted) == pytest.approx(-half, abs=0.1)
        assert max(planted) == pytest.approx(half, abs=0.1)


def test_the_gait_still_ends_with_every_foot_on_its_neutral_spot():
    frames = gait_keyframes(STANCE, Gait(Pattern.TRIPOD, 3, 40.0, turn_deg=10))
    assert np.abs(frames[-1].feet_mm - STANCE).max() < 1e-6
