"""choreo beats as a user runs it: the text, the JSON, the plot, and one line for a file that is
no song."""

from __future__ import annotations

import json
import os
import re
import subprocess

import numpy as np
import pytest
from cli_helpers import png_size
from fifo_helpers import fifo_that_never_blocks
from music_helpers import (
    BEAT_TOLERANCE_S,
    BPM_TOLERANCE,
    assert_beats_match,
    band_track,
    click_track,
    steady_times,
    write_clicks,
)

from choreo.cli import flag_of, main
from choreo.errors import ChoreoError
from choreo.music.beat_plot import HEIGHT_PX, WIDTH_PX
from choreo.music.beats import detect_beats
from choreo.music.decode import Audio, encode, ffmpeg_exe


def test_cli_json_and_plot(tmp_path, capsys):
    # 16 beats, four bars: enough for the tempo, the bars and the plot (each second of song
    # costs some 0.1 s of CPU to analyse)
    times = steady_times(100, 0.6, 10.0)
    song = write_clicks(tmp_path / "clicks.flac", times, 11.0)
    plot = tmp_path / "beats.png"
    assert main(["beats", str(song), "--json", "--plot", str(plot)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert abs(report["bpm"] - 100) <= BPM_TOLERANCE
    assert_beats_match(report["beats_s"], times)
    assert_beats_match(report["downbeats_s"], times[::4])
    assert png_size(plot) == (WIDTH_PX, HEIGHT_PX)


def test_cli_text_names_tempo_and_beats(tmp_path, capsys):
    song = write_clicks(tmp_path / "clicks.wav", steady_times(120, 0.5, 9.5), 10.0)
    assert main(["beats", str(song)]) == 0
    out = capsys.readouterr().out
    bpm = float(re.search(r"tempo ([\d.]+) BPM from 0.50", out).group(1))
    assert abs(bpm - 120) <= BPM_TOLERANCE
    assert "\nbeats (s):     0.50" in out and "\ndownbeats (s): 0.50" in out
    assert re.search(
        r"\nfor a motion: music: \{song: clicks.wav, start: 0.50\d, bpm: 12\d.\d\d\}", out
    )


def test_a_file_that_is_not_a_song_is_one_line(tmp_path, capsys):
    text = tmp_path / "notes.txt"
    text.write_text("la la la")
    assert main(["beats", str(text)]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: {text} is not a song file: use .wav, .flac, .ogg, .mp3\n"
    )
    assert main(["beats", "/dev/null"]) == 1  # the whole path: not "null is not a song file"
    assert capsys.readouterr().err == (
        "choreo: error: /dev/null is not a song file: use .wav, .flac, .ogg, .mp3\n"
    )
    broken = tmp_path / "broken.ogg"
    broken.write_bytes(b"OggS but not really")
    assert main(["beats", str(broken)]) == 1
    assert capsys.readouterr().err.startswith(f"choreo: error: cannot decode {broken.resolve()}")


def test_white_noise_has_no_steady_beat_and_no_music_suggestion(tmp_path, capsys):
    rng = np.random.default_rng(0)
    noise = Audio((0.3 * rng.standard_normal(22050 * 10)).astype(np.float32), 22050)
    song = encode(noise, tmp_path / "noise.wav")
    assert main(["beats", str(song)]) == 0
    out = capsys.readouterr().out
    assert "no steady beat" in out and "for a motion" not in out
    assert main(["beats", str(song), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["steady"] is False and report["confidence"] < 0.2 and report["music"] is None


def test_json_carries_the_music_block_stretches_meter_and_confidence(tmp_path, capsys):
    times = np.concatenate([steady_times(100, 0.3, 12), 12.3 + np.arange(30) * 60 / 130])
    song = encode(band_track(times), tmp_path / "change.wav")
    assert main(["beats", str(song), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    first = report["beats_s"][0]
    assert report["music"] == f"{{song: change.wav, start: {first:.3f}, beats: auto}}"
    assert [round(span["bpm"]) for span in report["tempi"]] == [100, 130]
    assert all(0.5 < span["confidence"] <= 1 for span in report["tempi"])
    assert report["change_points_s"] == pytest.approx([12.3], abs=BEAT_TOLERANCE_S)
    assert report["beats_per_bar"] == 4 and report["meter_detected"] is True
    assert report["steady"] is True and report["warnings"] == []


def test_the_alternative_grids_half_double_and_off_beat(tmp_path, capsys):
    times = steady_times(120, 0.5, 9.6)
    song = write_clicks(tmp_path / "clicks.wav", times, 10.0)
    reports = {}
    for options in (["--level", "double"], ["--level", "half"], ["--offset-beats", "0.5"]):
        assert main(["beats", str(song), "--json", "--meter", "4", *options]) == 0
        reports[options[1]] = json.loads(capsys.readouterr().out)
    middles = (times[:-1] + times[1:]) / 2
    assert_beats_match(reports["double"]["beats_s"], np.sort(np.concatenate([times, middles])))
    assert_beats_match(reports["half"]["beats_s"], times[::2])
    assert_beats_match(reports["0.5"]["beats_s"], middles)
    assert "try --level half" in reports["double"]["warnings"][0]  # 240 BPM
    assert "try --level double" in reports["half"]["warnings"][0]  # 60 BPM
    assert "(try --offset-beats 0.5)" in reports["0.5"]["warnings"][0]  # the clicks fall between
    # the library's warnings name its arguments; the command line's, its flags
    (off_beat,) = detect_beats(song, beats_per_bar=4, offset_beats=0.5).warnings
    assert "(try offset_beats 0.5)" in off_beat and "(try level double)" in off_beat
    assert main(["beats", str(song), "--meter", "4", "--offset-beats", "0.5"]) == 0
    assert f"warning: {off_beat.worded(flag_of)}" in capsys.readouterr().out.splitlines()
    assert "(try --offset-beats 0.5)" in off_beat.worded(flag_of)


def test_ffmpegs_own_text_does_not_reach_the_user(tmp_path, capsys):
    silent = tmp_path / "video_only.ogg"  # a real Ogg file holding only a video stream
    ffmpeg = [ffmpeg_exe(), "-v", "error", "-nostdin", "-f", "lavfi", "-i", "testsrc=size=32x32"]
    subprocess.run([*ffmpeg, "-t", "0.4", "-c:v", "libtheora", str(silent)], check=True)
    assert main(["beats", str(silent)]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: cannot decode {silent.resolve()}: it has no audio\n"
    )
    broken = tmp_path / "broken.ogg"
    broken.write_bytes(b"OggS but not really")
    assert main(["beats", str(broken)]) == 1
    err = capsys.readouterr().err
    assert "it is not a sound file ffmpeg can read" in err and " @ 0x" not in err


def test_a_folder_or_fifo_given_as_a_song_is_named_so(tmp_path, capsys):
    folder = tmp_path / "album.ogg"
    folder.mkdir()
    fifo = tmp_path / "stream.ogg"
    os.mkfifo(fifo)
    for path, kind in ((folder, "a folder"), (fifo, "a FIFO (named pipe)")):
        assert main(["beats", str(path)]) == 1
        assert capsys.readouterr().err == f"choreo: error: {path} is {kind}, not a song file\n"


def test_a_plot_that_cannot_be_written_is_refused_before_the_song_is_analysed(tmp_path, capsys):
    plot = tmp_path / "beats.png"
    with fifo_that_never_blocks(plot):
        assert main(["beats", str(tmp_path / "not_even_read.ogg"), "--plot", str(plot)]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: cannot write {plot}: it is a FIFO (named pipe), not a file\n"
    )


# --- bad input: each one line -------------------------------------------------------------------
def test_nan_samples_are_one_line_from_beats(tmp_path, capsys):
    import scipy.io.wavfile

    samples = click_track(steady_times(120, 0.5, 9.6), 10.0).samples.copy()
    samples[22050 * 2 : 22050 * 2 + 5] = np.nan
    song = tmp_path / "broken.wav"
    scipy.io.wavfile.write(song, 22050, samples)  # a float WAV, as an editor may export one
    assert main(["beats", str(song)]) == 1
    assert capsys.readouterr().err == (
        "choreo: error: the song holds 5 samples that are not numbers (NaN or infinite), the "
        "first at 2.000 s: repair or re-export it\n"
    )
    with pytest.raises(ChoreoError, match="not numbers"):
        detect_beats(Audio(samples, 22050))


def test_a_clip_too_short_for_a_steady_beat_says_how_many_beats(tmp_path, capsys):
    song = write_clicks(tmp_path / "short.wav", steady_times(120, 0.2, 3.3), 3.3)
    assert main(["beats", str(song)]) == 0
    out = capsys.readouterr().out
    assert "no steady beat: only 7 beats were found (a steady beat needs 8)" in out
    assert "for a motion" not in out


def test_silence_has_no_tempo_and_no_meter(tmp_path, capsys):
    song = encode(click_track([], 5.0), tmp_path / "silence.wav")
    assert main(["beats", str(song)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "silence.wav: 5.00 s, no beats found"
    assert "BPM" not in out and "beats to the bar" not in out
    assert main(["beats", str(song), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["bpm"] is None and report["beats_per_bar"] is None
    assert report["meter_confidence"] is None and report["meter_detected"] is True
    assert report["unsteady_because"] == "no beats were found" and report["music"] is None
    assert main(["beats", str(song), "--json", "--meter", "3"]) == 0  # a given meter is kept
    assert json.loads(capsys.readouterr().out)["beats_per_bar"] == 3


def test_an_offset_of_more_than_four_bars_is_refused(tmp_path, capsys):
    song = write_clicks(tmp_path / "clicks.wav", steady_times(120, 0.5, 9.5), 10.0)
    assert main(["beats", str(song), "--offset-beats", "1e308"]) == 2  # a usage error
    assert capsys.readouterr().err == (
        "choreo: error: --offset-beats must be a number >= -16 and <= 16 beats, got 1e+308\n"
    )
    with pytest.raises(ChoreoError, match="offset_beats must be"):
        detect_beats(song, offset_beats=-17)
