"""Meters and downbeats from synthetic features (no audio, no librosa): each meter from 2 to 7
found by the same test, the downbeats following a bar that restarts after a gap."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.music.bars import (
    LOCAL_BEATS,
    METERS,
    find_bars,
    harmonic_change,
    locally_standardised,
)
from choreo.music.features import COARSE_HOP, Features

RATE_HZ = 22050
FPS = RATE_HZ / COARSE_HOP
CHORDS = ((0, 4, 7), (9, 0, 4), (5, 9, 0), (7, 11, 2), (2, 5, 9))  # C Am F G Dm


def features_of(beats_s, per_bar: int, first_downbeat: int = 0, downbeats=None) -> Features:
    """Envelopes as a band would give them: a kick and a new chord (with its bass) on each
    downbeat (every ``per_bar`` beats from ``first_downbeat``, or the ``downbeats`` given), a
    snare on the other beats, a little noise everywhere."""
    if downbeats is None:
        downbeats = range(first_downbeat, len(beats_s), per_bar)
    downbeats = set(downbeats)
    rng = np.random.default_rng(0)
    frames = int((beats_s[-1] + 1.0) * FPS)
    low, snare = rng.uniform(0, 0.2, frames), rng.uniform(0, 0.2, frames)
    onset, rms = rng.uniform(0, 0.2, frames), 0.5 + rng.uniform(0, 0.05, frames)
    chroma = rng.uniform(0, 0.05, (12, frames))
    bars = 0
    for k, at in enumerate(beats_s):
        f = int(round(at * FPS))
        onset[f] += 1.0
        if k in downbeats:
            low[f] += 1.0
            bars += 1
        else:
            snare[f] += 1.0
        chord = CHORDS[(bars - 1) % len(CHORDS)] if k >= first_downbeat else (2, 7, 11)
        end = int(round(beats_s[k + 1] * FPS)) if k + 1 < len(beats_s) else frames
        chroma[list(chord), f:end] += 1.0
    fine = np.repeat(onset, COARSE_HOP // 64)
    return Features(onset, low, snare, chroma.copy(), chroma, fine, rms, RATE_HZ)


@pytest.mark.parametrize("per_bar", METERS)
def test_each_meter_from_2_to_7_is_found_by_the_same_test(per_bar):
    beats = 0.5 + np.arange(12 * per_bar) * 0.5
    bars = find_bars(features_of(beats, per_bar), beats)
    assert bars.beats_per_bar == per_bar
    assert list(bars.downbeats) == list(range(0, len(beats), per_bar))


def test_a_given_meter_is_kept_and_a_pickup_is_not_a_bar():
    beats = 0.5 + np.arange(40) * 0.5
    bars = find_bars(features_of(beats, 4, first_downbeat=2), beats, given=4)
    assert bars.beats_per_bar == 4 and bars.confidence == 1.0
    assert list(bars.downbeats) == list(range(2, 40, 4))


def test_after_a_gap_the_bars_restart_where_the_music_does():
    first = 0.5 + np.arange(30) * 0.5  # 7 bars and a half, then 3 s of silence
    second = first[-1] + 3.0 + np.arange(32) * 0.5  # the band comes back on a downbeat
    beats = np.concatenate([first, second])
    downbeats = [*range(0, 30, 4), *range(30, 62, 4)]
    bars = find_bars(features_of(beats, 4, downbeats=downbeats), beats, given=4)
    assert list(bars.downbeats) == downbeats  # counting on would put them on beat 3 after it


def test_harmonic_change_is_over_bars_not_beat_to_beat():
    # a walking bass: a new note every beat, the same four notes each bar for two bars, then new
    walk = [0, 4, 7, 9] * 2 + [5, 9, 0, 2] * 2
    chroma = np.eye(12)[walk]
    change = harmonic_change(chroma, 4)
    assert np.argmax(change[4:]) + 4 == 8  # where the bars change, not where the notes do
    assert change[4] == pytest.approx(0.0)  # bar 2 repeats bar 1: no change at its downbeat


def test_a_quiet_section_s_downbeats_stand_out_like_a_loud_one_s():
    # a quiet intro whose downbeats are 0.2 above its other beats, then a loud band whose are 1.0
    # above: against the whole song, every beat of the intro would be below every beat of the band
    quiet, loud = np.tile([0.3, 0.1, 0.1, 0.1], 32), np.tile([6.0, 5.0, 5.0, 5.0], 32)
    cue = locally_standardised(np.concatenate([quiet, loud]))
    beat = np.arange(len(cue))
    away = np.abs(beat - 127.5) > 2.5 * LOCAL_BEATS  # near the change the sections blend
    downbeat = beat % 4 == 0
    assert cue[away & downbeat].min() > cue[away & ~downbeat].max()
