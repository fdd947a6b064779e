"""Beat detection (``choreo beats``) on click tracks whose beats are known by construction."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest
from music_helpers import (
    BEAT_TOLERANCE_S,
    BPM_TOLERANCE,
    assert_beats_match,
    band_track,
    click_track,
    steady_times,
    write_clicks,
)

from choreo.errors import ChoreoError
from choreo.music.beats import detect_beats
from choreo.music.decode import Audio, decode_song

# librosa warmed once per session (see conftest.py), not in the first test that calls it
pytestmark = pytest.mark.usefixtures("warm_librosa")


@pytest.mark.parametrize(("bpm", "first_s"), [(120.0, 0.0), (97.0, 0.37), (143.5, 1.1)])
def test_steady_clicks_give_their_tempo_and_beats(bpm, first_s):
    # 15 s: 24 to 33 clicks; the tempo comes within 0.005 BPM, as from 30 s
    times = steady_times(bpm, first_s, 14.5)
    analysis = detect_beats(click_track(times, 15.0))
    assert abs(analysis.bpm - bpm) <= BPM_TOLERANCE
    assert_beats_match(analysis.beats_s, times)
    assert_beats_match(analysis.downbeats_s, times[::4])  # the accented clicks


def test_a_tempo_change_gives_two_tempi():
    first = np.arange(0.5, 10.0, 60 / 120)  # 19 clicks, then 20: each tempo within 0.01 BPM
    second = first[-1] + np.cumsum(np.full(20, 60 / 100))
    times = np.concatenate([first, second])
    analysis = detect_beats(click_track(times, times[-1] + 1.0))
    assert_beats_match(analysis.beats_s, times)
    assert [round(span.bpm) for span in analysis.tempi] == [120, 100]
    assert abs(analysis.tempi[0].bpm - 120) <= BPM_TOLERANCE
    assert abs(analysis.tempi[1].bpm - 100) <= BPM_TOLERANCE
    assert abs(analysis.tempi[1].start_s - first[-1]) <= BEAT_TOLERANCE_S + 60 / 100


def test_three_four_time_finds_the_bars():
    times = steady_times(90, 0.25, 20)
    analysis = detect_beats(click_track(times, 20.5, accent_every=3), beats_per_bar=3)
    assert_beats_match(analysis.downbeats_s, times[::3])


def test_silence_has_no_beats():
    analysis = detect_beats(click_track([], 5.0))
    assert analysis.beats_s == () and analysis.bpm == 0.0


@pytest.mark.parametrize("suffix", [".wav", ".flac", ".ogg", ".mp3"])
def test_every_song_format_decodes_with_its_clicks_in_place(tmp_path, suffix):
    times = steady_times(120, 0.5, 9.5)
    song = write_clicks(tmp_path / f"clicks{suffix}", times, 10.0)
    audio = decode_song(song)
    assert abs(audio.duration_s - 10.0) < 0.06
    assert_beats_match(detect_beats(audio).beats_s, times)


def test_a_song_s_path_is_detected_as_its_decoded_samples(tmp_path):
    times = steady_times(120, 0.5, 9.5)
    song = write_clicks(tmp_path / "clicks.ogg", times, 10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # its last block, shorter than a bass window, is no warning
        from_path, from_samples = detect_beats(song), detect_beats(decode_song(song))
    assert from_path == from_samples
    assert_beats_match(from_path.beats_s, times)
    assert detect_beats(str(song)) == from_path


def test_without_librosa_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "librosa", None)  # import librosa now raises ImportError
    with pytest.raises(ChoreoError, match=r"pip install 'choreo\[music\]'"):
        detect_beats(click_track(steady_times(120, 0.5, 4), 5.0))


def test_noise_and_a_buzz_give_increasing_beats_and_end():
    rng = np.random.default_rng(0)
    noise = Audio((0.3 * rng.standard_normal(22050 * 8)).astype(np.float32), 22050)
    buzz = click_track(np.arange(0.0, 6.0, 0.02), 6.5)  # 3000 clicks a minute: below a beat
    for audio in (noise, buzz):
        beats = np.asarray(detect_beats(audio).beats_s)
        assert np.all(np.diff(beats) > 0) and np.all((beats >= 0) & (beats <= audio.duration_s))


# --- songs with a band: meter, downbeats, tempo changes, confidence ------------------------------


def test_a_backbeat_with_a_loud_snare_has_its_bars_on_the_kick_and_chord():
    times = steady_times(104, 0.3, 16)
    analysis = detect_beats(band_track(times, snare_gain=1.0))  # the meter is not given
    assert analysis.meter_detected and analysis.beats_per_bar == 4
    assert_beats_match(analysis.beats_s, times)
    assert_beats_match(analysis.downbeats_s, times[::4])  # not on the snare's beat 2


def test_a_waltz_is_found_to_be_in_three():
    times = steady_times(138, 0.3, 16)
    analysis = detect_beats(band_track(times, per_bar=3))
    assert analysis.beats_per_bar == 3 and analysis.meter_confidence > 0.5
    assert_beats_match(analysis.downbeats_s, times[::3])


def test_a_tempo_change_in_a_song_is_followed_across_it():
    times = np.concatenate([steady_times(100, 0.3, 12), 12.3 + np.arange(30) * 60 / 130])
    analysis = detect_beats(band_track(times))
    assert_beats_match(analysis.beats_s, times)
    assert [round(span.bpm) for span in analysis.tempi] == [100, 130]
    assert analysis.change_points_s == pytest.approx([12.3], abs=BEAT_TOLERANCE_S)
    assert all(span.confidence > 0.5 for span in analysis.tempi)


def test_a_pickup_is_not_a_bar():
    times = steady_times(116, 0.3, 16)
    analysis = detect_beats(band_track(times, pickup=2))
    assert_beats_match(analysis.downbeats_s, times[2::4])


def test_detection_needs_little_more_memory_than_the_samples():
    import tracemalloc

    audio = click_track(steady_times(120, 0.5, 119), 120.0)
    detect_beats(click_track(steady_times(120, 0.5, 5), 6.0))  # librosa's own first-use caches
    tracemalloc.start()
    try:
        detect_beats(audio)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * audio.samples.nbytes  # whole-song spectrograms took 13 times as much


def sixteenths_band(bpm: float, bars: int, parts: dict[str, tuple[int, ...]]) -> Audio:
    """A band in 4/4 at ``bpm`` from 0.5 s: each of ``parts`` (kick, snare, hat, bass, keys)
    struck on the sixteenths of every bar it lists (0 to 15); bass and keys on a root that
    changes every bar."""
    rng = np.random.default_rng(0)
    sixteenth_s = 15 / bpm
    samples = np.zeros(int((0.5 + bars * 16 * sixteenth_s + 1.0) * 22050), np.float32)
    t = np.arange(int(0.3 * 22050)) / 22050
    fade = np.minimum((0.3 - t) / 0.02, 1)  # no click where a sound is cut
    sounds = {
        "kick": np.sin(2 * np.pi * np.cumsum(45 + 110 * np.exp(-t / 0.03)) / 22050)
        * np.exp(-t / 0.1),
        "snare": 0.6 * np.diff(rng.standard_normal(len(t) + 1)) * np.exp(-t / 0.05),
        "hat": 0.05 * np.diff(rng.standard_normal(len(t) + 2), 2) * np.exp(-t / 0.01),
    }
    for bar in range(bars):
        root_hz = (65.4, 55.0, 43.7, 49.0)[bar % 4]
        sounds["bass"] = 0.5 * np.sin(2 * np.pi * root_hz * t) * np.exp(-t / 0.2)
        sounds["keys"] = 0.5 * np.sin(2 * np.pi * 5 * root_hz * t) * np.exp(-t / 0.2)
        for part, sixteenths in parts.items():
            for s in sixteenths:
                i = int(round((0.5 + (16 * bar + s) * sixteenth_s) * 22050))
                n = min(len(t), len(samples) - i)
                samples[i : i + n] += (sounds[part] * fade)[:n]
    return Audio(samples / np.max(np.abs(samples)), 22050)


def test_funk_s_syncopated_kick_and_bass_do_not_pull_the_beats_off_the_backbeat():
    # kick on 1, the a of 1 and the and of 3, the bass mostly off the beat, sixteenth hats, the
    # snare on 2 and 4: counting the low band twice, the tracker alone sat on the off-beats
    funk = {
        "kick": (0, 3, 10),
        "snare": (4, 12),
        "hat": tuple(range(16)),
        "bass": (0, 3, 6, 8, 11, 14),
        "keys": (5, 14),
    }
    analysis = detect_beats(sixteenths_band(100, 8, funk))
    times = 0.5 + np.arange(32) * 0.6
    assert_beats_match(analysis.beats_s, times)
    assert_beats_match(analysis.downbeats_s, times[::4])
