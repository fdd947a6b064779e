"""choreo.music.tracker: librosa's dynamic-programming beat tracker without importing
librosa.beat (which compiles a function with numba at every import): the same beats as
``librosa.beat.beat_track`` on the same envelope, at one tempo and at a tempo per frame."""

from __future__ import annotations

import functools
import importlib
import sys

import librosa
import numpy as np
import pytest
from music_helpers import assert_beats_match, band_track, click_track, steady_times

from choreo.music.beats import detect_beats
from choreo.music.features import COARSE_HOP, normalised, song_features
from choreo.music.tempo import local_tempo
from choreo.music.tracker import track_beats

RATE_HZ = 22050
FRAME_RATE_HZ = RATE_HZ / COARSE_HOP


@functools.cache
def librosa_beat():
    """librosa.beat, its one numba function librosa leaves uncached (``__beat_local_score``,
    compiled at every import: 2 to 3.5 s of CPU) cached like the others, in the NUMBA_CACHE_DIR
    conftest.py sets (not in librosa's site-packages): librosa's own code, compiled once per
    machine instead of once per run."""
    import numba

    guvectorize = numba.guvectorize

    def cached(*args, **kwargs):
        return guvectorize(*args, **{**kwargs, "cache": True})

    numba.guvectorize = cached  # read as librosa.beat's decorators run, at its import
    try:
        return importlib.import_module("librosa.beat")
    finally:
        numba.guvectorize = guvectorize


def librosas(envelope: np.ndarray, bpm) -> np.ndarray:
    _, frames = librosa_beat().beat_track(
        onset_envelope=envelope, sr=RATE_HZ, hop_length=COARSE_HOP, trim=False, bpm=bpm
    )
    return frames


@functools.cache
def song_envelope(song: str) -> tuple[np.ndarray, object]:
    """The envelope choreo tracks (onsets and low band) of one of SONGS and its local tempo,
    found once for the three tempo scales."""
    audio = SONGS[song]()
    features = song_features(librosa, audio.samples, audio.rate_hz)
    envelope = normalised(features.onset) + normalised(features.low)
    return envelope, local_tempo(librosa, envelope, features.rate_hz)


SONGS = {  # made when the test runs, not at collection
    "steady clicks": lambda: click_track(steady_times(120, 0.25, 14.0), 15.0),
    "a band changing tempo": lambda: band_track(
        np.concatenate([steady_times(100, 0.3, 12), 12.3 + np.arange(30) * 60 / 130])
    ),
}


@pytest.mark.parametrize("song", SONGS)
@pytest.mark.parametrize("scale", [1.0, 2.0, 0.5])
def test_a_songs_beats_are_librosas_at_its_tempo_and_at_each_frames(song, scale):
    envelope, tempo = song_envelope(song)
    for bpm in (scale * tempo.median_bpm, scale * tempo.bpm):
        ours = track_beats(librosa, envelope, bpm, FRAME_RATE_HZ)
        assert len(ours) > 5
        np.testing.assert_array_equal(ours, librosas(envelope, bpm))


@pytest.mark.parametrize("seed", range(12))
def test_sparse_random_onsets_give_librosas_beats(seed):
    """Scattered onsets of random strength after a silence, at a random tempo (even seeds) or
    a random tempo per frame (odd): near ties in the scores included."""
    rng = np.random.default_rng(seed)
    count = int(rng.integers(50, 3000))
    envelope = (np.abs(rng.standard_normal(count)) * (rng.random(count) < 0.3)).astype(np.float32)
    envelope[: int(rng.integers(0, 40))] = 0
    bpm = rng.uniform(60, 200, count) if seed % 2 else rng.uniform(40, 240)
    np.testing.assert_array_equal(
        track_beats(librosa, envelope, bpm, FRAME_RATE_HZ), librosas(envelope, bpm)
    )


def test_an_envelope_without_onsets_has_no_beats():
    assert len(track_beats(librosa, np.zeros(500, np.float32), 120.0, FRAME_RATE_HZ)) == 0


def test_beat_detection_does_not_import_librosa_beat(monkeypatch):
    """librosa.beat compiles with numba at every import (some 3 s of CPU): unreachable here, the
    beats are still found."""
    monkeypatch.delattr(librosa, "beat", raising=False)
    monkeypatch.setitem(sys.modules, "librosa.beat", None)  # importing it raises ImportError
    with pytest.raises(ImportError):
        importlib.import_module("librosa.beat")
    times = steady_times(120, 0.5, 9.5)
    analysis = detect_beats(click_track(times, 10.0))
    assert_beats_match(analysis.beats_s, times)
