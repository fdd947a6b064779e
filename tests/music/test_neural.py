"""The neural tracker's seam (``--tracker beat-this``): what choreo does with Beat This!'s beats
and downbeats, with a stand-in for the package (its weights cannot be fetched in the tests), and
the one line said where it is missing."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest
from music_helpers import click_track, steady_times, write_clicks

from choreo.cli import main
from choreo.errors import ChoreoError
from choreo.music.beats import detect_beats

pytestmark = pytest.mark.usefixtures("warm_librosa")

TIMES = steady_times(120, 0.5, 11.5)  # 22 clicks, accented every 4 from the first


def stand_in(monkeypatch, beats, downbeats, fail: Exception | None = None) -> list:
    """``beat_this.inference.Audio2Beats`` replaced: it returns ``beats`` and ``downbeats``
    (or raises ``fail`` when built, as a hub without network would); the calls are recorded."""
    calls: list = []

    class Audio2Beats:
        def __init__(self, **options):
            if fail is not None:
                raise fail
            calls.append(options)

        def __call__(self, samples, rate_hz):
            calls.append((len(samples), rate_hz))
            return beats, downbeats

    inference = types.ModuleType("beat_this.inference")
    inference.Audio2Beats = Audio2Beats
    monkeypatch.setitem(sys.modules, "beat_this", types.ModuleType("beat_this"))
    monkeypatch.setitem(sys.modules, "beat_this.inference", inference)
    return calls


def test_its_beats_and_bars_are_taken_with_choreos_tempo_and_confidence(monkeypatch):
    audio = click_track(TIMES, 12.0)
    calls = stand_in(monkeypatch, TIMES, TIMES[1::3])  # it says 3 to the bar, from click 1
    analysis = detect_beats(audio, tracker="beat-this")
    assert calls == [{"checkpoint_path": "final0", "device": "cpu", "dbn": False}, (264600, 22050)]
    assert analysis.beats_s == pytest.approx(TIMES)
    assert analysis.downbeats_s == pytest.approx(TIMES[1::3])
    assert analysis.beats_per_bar == 3 and analysis.meter_detected
    assert analysis.bpm == pytest.approx(120, abs=0.01) and analysis.steady
    given = detect_beats(audio, beats_per_bar=4, tracker="beat-this")  # a given meter: our bars
    assert given.downbeats_s == pytest.approx(TIMES[::4], abs=0.001)


def test_without_it_or_its_weights_the_tracker_is_one_line(tmp_path, monkeypatch, capsys):
    song = write_clicks(tmp_path / "clicks.wav", TIMES, 12.0)
    monkeypatch.setitem(sys.modules, "beat_this", None)  # import beat_this now raises
    monkeypatch.setitem(sys.modules, "beat_this.inference", None)
    assert main(["beats", str(song), "--tracker", "beat-this"]) == 1
    assert capsys.readouterr().err == (
        "choreo: error: the beat-this tracker needs Beat This! and torch: install the extra, "
        "pip install 'choreo[beats-neural]'\n"
    )
    stand_in(monkeypatch, TIMES, TIMES[::4], fail=OSError("network unreachable"))
    with pytest.raises(ChoreoError, match=r"could not load its weights \(final0\): network"):
        detect_beats(song, tracker="beat-this")
    with pytest.raises(ChoreoError, match="tracker"):
        detect_beats(song, tracker="madmom")
    assert np.all(np.diff(detect_beats(song).beats_s) > 0)  # the default needs none of it
