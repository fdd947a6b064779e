"""The beat report of an analysis given by hand (so no detector runs): its numbers as JSON-ready
values, and the music block it suggests for a motion."""

from __future__ import annotations

import json

import pytest

from choreo.errors import OptionError
from choreo.music.beats import BeatAnalysis, TempoSpan
from choreo.music.report import beats_report, suggested_music

BEATS_S = tuple(0.5 + 0.5 * n for n in range(16))  # 120 BPM from 0.5 s


STEADY = (TempoSpan(0.5, 8.0, 120.0, 0.9),)


def waltz(tempi=STEADY) -> BeatAnalysis:
    return BeatAnalysis(
        duration_s=9.0, beats_s=BEATS_S, downbeats_s=BEATS_S[1::3], beats_per_bar=3, tempi=tempi
    )


def test_the_report_is_plain_json_with_the_suggested_block(tmp_path):
    report = beats_report(tmp_path / "waltz.ogg", waltz())
    assert json.loads(json.dumps(report)) == report
    assert report["bpm"] == 120.0 and report["beats_per_bar"] == 3
    assert report["downbeats_s"] == [1.0, 2.5, 4.0, 5.5, 7.0]
    assert report["music"] == "{song: waltz.ogg, start: 1.000, bpm: 120.00, meter: 3/4}"


def test_a_song_whose_tempo_changes_gets_beats_auto_with_the_grid_asked(tmp_path):
    changing = waltz((TempoSpan(0.5, 4.0, 120.0), TempoSpan(4.0, 8.0, 126.0)))
    block = suggested_music(tmp_path / "song.wav", changing, "double", 0.5)
    assert block == (
        "{song: song.wav, start: 1.000, beats: auto, level: double, offset_beats: 0.5, meter: 3/4}"
    )


def test_no_steady_beat_suggests_no_block(tmp_path):
    assert suggested_music(tmp_path / "noise.wav", waltz(tempi=())) is None


def test_an_unknown_level_is_refused_by_name(tmp_path):
    with pytest.raises(OptionError) as refused:
        beats_report(tmp_path / "song.wav", waltz(), level="quadruple")
    assert refused.value.option == "level"
