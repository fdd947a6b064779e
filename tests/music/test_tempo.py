"""The local tempo at one level: stretches at twice the dominant tempo folded onto it, a real
change of tempo kept (onset envelopes made here: pulses at known times, librosa's tempogram)."""

from __future__ import annotations

import librosa
import numpy as np
import pytest

from choreo.music.features import COARSE_HOP
from choreo.music.tempo import local_tempo

RATE_HZ = 22050
FPS = RATE_HZ / COARSE_HOP


def pulses(times_s: np.ndarray, strengths: np.ndarray) -> np.ndarray:
    """An onset envelope: a one-frame pulse of each strength at each time, 1 s of quiet after."""
    envelope = np.zeros(int((times_s.max() + 1.0) * FPS))
    np.add.at(envelope, np.round(times_s * FPS).astype(int), strengths)
    return envelope


def test_a_stretch_at_twice_the_tempo_is_folded_onto_the_song_s_level():
    # a 60 BPM song whose eighths are as strong as its beats from 12 s to 26 s: a ballad whose
    # piano plays eighths there reads 120 in those windows
    beats = np.arange(0.5, 40.0, 1.0)
    eighths = beats + 0.5
    loud = np.where((eighths > 12) & (eighths < 26), 1.0, 0.0)
    envelope = pulses(np.concatenate([beats, eighths]), np.concatenate([np.ones(40), loud]))
    tempo = local_tempo(librosa, envelope, RATE_HZ)
    assert tempo.dominant_bpm == pytest.approx(60, rel=0.01)
    assert np.all(np.abs(tempo.bpm / 60 - 1) <= 0.02)  # 117 BPM in the middle without the fold
    assert tempo.steady


def test_a_real_change_by_four_thirds_is_kept():
    # 100 BPM for 20 s, then 133 (4/3 of it): no onsets repeat at the old period after the change
    first = np.arange(0.5, 20.0, 0.6)
    second = first[-1] + np.arange(1, 45) * 0.45
    times = np.concatenate([first, second])
    tempo = local_tempo(librosa, pulses(times, np.ones(len(times))), RATE_HZ)
    before, after = tempo.bpm[: int(15 * FPS)], tempo.bpm[-int(15 * FPS) :]
    assert np.all(np.abs(before / 100 - 1) <= 0.02)
    assert np.all(np.abs(after / 133.3 - 1) <= 0.03)  # lags are coarse: 136 BPM is one frame
    assert not tempo.steady
