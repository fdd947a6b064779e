"""The recording's durable side: a stream reduced to the samples that keep every joint within the
tolerance, and nothing to resume where no journal was left (the journal's resume and its damage
are tested with a recorder in tests/play/test_recorder.py)."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.errors import ChoreoError
from choreo.play.recording import (
    Recording,
    douglas_peucker,
)


def test_nothing_to_resume(tmp_path):
    with pytest.raises(ChoreoError, match="nothing to resume"):
        Recording.resume(tmp_path / "t.yaml")


def test_douglas_peucker_keeps_the_corners():
    times = [0, 1, 2, 3, 4]
    assert douglas_peucker(times, [[0], [1], [2], [3], [4]], 0.1) == [0, 4]
    assert douglas_peucker(times, [[0], [1], [2], [1], [0]], 0.5) == [0, 2, 4]
    assert douglas_peucker(times, [[0], [1], [2], [1], [0]], 2.5) == [0, 4]
    # a bump on the second joint alone is kept
    assert douglas_peucker(times, [[0, 0], [1, 0], [2, 3], [3, 0], [4, 0]], 1.0) == [0, 1, 2, 3, 4]
    # uneven times: a constant speed along time is a straight line
    assert douglas_peucker([0, 0.1, 0.5, 2.0], [[0], [1], [5], [20]], 0.01) == [0, 3]


def test_douglas_peucker_stays_within_tolerance_of_every_sample():
    rng = np.random.default_rng(7)
    times = np.cumsum(rng.uniform(0.02, 0.08, 300))
    angles = np.cumsum(rng.normal(0, 1.5, (300, 3)), axis=0)
    for tolerance in (0.5, 2.0, 8.0):
        kept = douglas_peucker(times, angles, tolerance)
        assert kept[0] == 0 and kept[-1] == 299 and kept == sorted(set(kept))
        for joint in range(3):
            line = np.interp(times, times[kept], angles[kept, joint])
            assert np.abs(line - angles[:, joint]).max() <= tolerance + 1e-9
