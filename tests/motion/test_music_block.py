"""The music block of motion files: beat- and bar-timed keyframes, checked and planned."""

from __future__ import annotations

import json
import sys

import jsonschema
import numpy as np
import pytest
import yaml
from cli_helpers import error_line
from music_helpers import click_track, steady_times, write, write_clicks
from paths import REPO

from choreo.cli import main
from choreo.errors import OptionError, PlanningError, SourceError
from choreo.motion.motion_file import load_motion
from choreo.music.beats import detect_beats
from choreo.music.decode import Audio, decode_song, encode
from choreo.plan.planner import plan_motion
from choreo.play.play_motion import play_motion
from choreo.play.play_options import PlayOptions

# librosa warmed once per session (see conftest.py), not in the first test that calls it
pytestmark = pytest.mark.usefixtures("warm_librosa")


@pytest.fixture
def song(tmp_path):
    """A 10 s click track at 120 BPM whose first click is 0.5 s in (so 19 beats from there)."""
    return write_clicks(tmp_path / "song.wav", steady_times(120, 0.5, 9.6), 10.0)


def problems_of(path) -> list[str]:
    with pytest.raises(SourceError) as caught:
        load_motion(path)
    return caught.value.problems


def plan_json(capsys, path) -> dict:
    assert main(["plan", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_beat_timed_keyframes_land_on_the_beats_in_the_plan(tmp_path, song, capsys):
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            beat: 3
          - pose: {shoulder: -20}
            beat: 4.5
          - pose: {base_yaw: 30}
            bar: 3
          - pose: home
            bar: 4
            beat: 2
        """,
    )
    report = plan_json(capsys, path)
    beat_s = 60 / 120  # beat n at (n - 1) beats after start
    expected = [0, 2 * beat_s, 3.5 * beat_s, 8 * beat_s, 13 * beat_s]
    assert report["keyframe_times_s"] == pytest.approx(expected, abs=1e-9)
    assert report["music"]["start_s"] == 0.5
    assert report["music"]["beat_times_s"][:3] == pytest.approx([0, 0.5, 1.0])
    assert len(report["music"]["beat_times_s"]) == 19  # beats 1..19 fit in 9.5 s of song


def test_beats_auto_uses_the_songs_own_beats(tmp_path, capsys):
    times = np.concatenate([steady_times(120, 1.0, 6.0), 6.0 + np.arange(10) * 60 / 100])
    write_clicks(tmp_path / "drift.ogg", times, times[-1] + 0.5)
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: drift.ogg, start: 1.0, beats: auto}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            beat: 5
          - pose: {shoulder: -20}
            beat: 13
          - pose: {shoulder: 0}
            bar: 4
            beat: 3
        """,
    )
    # beat n is the n-th click from 1.0 s on, tempo change included; bar 4 beat 3 is beat 15
    wanted = times[[0, 4, 12, 14]] - 1.0
    got = np.array(plan_json(capsys, path)["keyframe_times_s"])
    assert np.max(np.abs(got - wanted)) <= 0.015


def test_an_included_file_dances_to_the_including_motions_music(tmp_path, song, capsys):
    write(
        tmp_path,
        "step.yaml",
        """
        robot: arm6
        keyframes:
          - pose: {elbow: 30}
            beat: 1
          - pose: {elbow: -30}
            beat: 3
        """,
    )
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
          - include: step.yaml
            bar: 2
        """,
    )
    # the block starts on bar 2 (beat 5, t 2.0) and keeps its two-beat spacing
    assert plan_json(capsys, path)["keyframe_times_s"] == pytest.approx([0, 2.0, 3.0])


def test_a_beat_past_the_end_of_the_song_says_where_and_how_many(tmp_path, song):
    path = write(
        tmp_path,
        "late.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
          - pose: {shoulder: 20}
            beat: 20
          - pose: {shoulder: 10}
            bar: 6
        """,
    )
    assert problems_of(path) == [
        f"{path}:6:11: beat 20 is past the end of the song: song.wav has 19 beats after start "
        "0.5 s (the last is beat 19, bar 5 beat 3, at t 9.000); give an earlier beat",
        f"{path}:8:10: bar 6 is past the end of the song: song.wav has 19 beats after start "
        "0.5 s (the last is beat 19, bar 5 beat 3, at t 9.000); give an earlier beat",
    ]


def test_an_unreachable_beat_names_the_earliest_beat_that_works(tmp_path, song):
    path = write(
        tmp_path,
        "rush.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
            beat: 1
          - pose: {base_yaw: 120, shoulder: 80}
            beat: 1.5
        """,
    )
    motion = load_motion(path)
    with pytest.raises(PlanningError) as caught:
        plan_motion(motion)
    message = str(caught.value)
    assert message.startswith(f"{path}:6:5: keyframe cannot be reached at 0.250 s")
    earliest_s = float(message.split(" allow ")[1].split(" s")[0])
    first_beat = int(np.ceil(earliest_s / 0.5 - 1e-9)) + 1  # beat n is at (n - 1) * 0.5 s
    assert first_beat > 2
    assert f"use beat {first_beat} or later (t {(first_beat - 1) * 0.5:.3f})" in message
    stretched = write(
        tmp_path, "ok.yaml", path.read_text().replace("beat: 1.5", f"beat: {first_beat}")
    )
    plan_motion(load_motion(stretched))  # the beat it names works


def test_music_problems_are_each_one_line(tmp_path, song):
    (tmp_path / "notes.txt").write_text("no")
    path = write(
        tmp_path,
        "bad.yaml",
        """
        robot: arm6
        music: {song: notes.txt, bpm: 120}
        keyframes:
          - pose: home
            beat: 1
            t: 0
        """,
    )
    assert problems_of(path) == [
        f"{path}:2:15: song: {tmp_path}/notes.txt is not a song file: use .wav, .flac, .ogg, "
        ".mp3 "
        "(paths are relative to this file's folder)",
        f"{path}:6:5: give at most one of t (arrival time from the motion start), beat/bar "
        "(a beat of the music) and after (delay after the previous keyframe); remove one",
    ]


@pytest.mark.parametrize(
    ("music", "column", "message"),
    [
        (
            "{song: song.wav}",
            "8",
            "the music block needs exactly one of bpm (a fixed tempo, beats per minute) and "
            "beats: auto (the beats detected in the song)",
        ),
        (
            "{song: song.wav, bpm: 120, meter: four}",
            "42",
            "meter 'four' is not a time signature; write it like 4/4, 3/4 or 6/8",
        ),
        (
            "{song: song.wav, bpm: 120, start: 12}",
            "42",
            "start 12 is past the end of song.wav (10.000 s); give a time inside the song",
        ),
        (
            "{song: missing.ogg, bpm: 120}",
            "15",
            "song: {folder}/missing.ogg does not exist (paths are relative to this file's folder)",
        ),
    ],
)
def test_a_bad_music_block_is_reported_at_its_place(tmp_path, song, music, column, message):
    path = write(tmp_path, "bad.yaml", f"robot: arm6\nmusic: {music}\nkeyframes:\n  - pose: home\n")
    assert problems_of(path) == [f"{path}:2:{column}: {message.format(folder=tmp_path)}"]


def test_a_beat_needs_music_and_speed_would_leave_it_behind(tmp_path, song):
    path = write(
        tmp_path,
        "deaf.yaml",
        """
        robot: arm6
        keyframes:
          - pose: home
            beat: 1
        """,
    )
    assert problems_of(path) == [
        f"{path}:4:5: beat needs a music block (music: with song and bpm or beats: auto) in "
        "this motion or the one including it; or time the keyframe with t or after"
    ]
    fast = write(
        tmp_path,
        "fast.yaml",
        """
        robot: arm6
        speed: 2
        music: {song: song.wav, bpm: 120}
        keyframes:
          - pose: home
        """,
    )
    assert problems_of(fast) == [
        f"{fast}:2:8: speed 2 would leave the music behind (the song plays at its own tempo); "
        "remove speed, or the music block"
    ]


DANCES = [
    REPO / "motions" / "arm6" / "dance.yaml",
    REPO / "motions" / "tonypi" / "dance.yaml",
    REPO / "motions" / "hexapod18" / "dance.yaml",
]


def test_the_shipped_dances_validate_and_keep_to_their_song(capsys):
    # planned and compiled here; simulated (no fall, no warning either) with every shipped motion
    # in tests/preview/test_preview_shipped.py, which is where that seconds-long physics is paid
    assert main(["validate", "--no-physics", *map(str, DANCES)]) == 0
    song = REPO / "motions" / "songs" / "groove.ogg"
    assert song.stat().st_size < 500_000
    detected = detect_beats(decode_song(song))
    for path in DANCES:
        music = load_motion(path).music
        assert music.song.resolve() == song.resolve()
        # the written tempo and start are the song's own: beat n sounds where the detector hears it
        heard = np.asarray(detected.beats_s)  # 36 kicks; the grid goes on into the last second
        written = music.start_s + np.asarray(music.grid.beat_times_s[: len(heard)])
        assert abs(detected.bpm - music.bpm) <= 0.5
        assert len(heard) == 36 and np.max(np.abs(heard - written)) <= 0.015
        assert detected.downbeats_s[0] == pytest.approx(music.start_s, abs=0.015)


def test_a_shipped_dance_on_detected_beats_keeps_its_times(tmp_path):
    import shutil

    shutil.copytree(REPO / "motions" / "songs", tmp_path / "songs")
    shutil.copytree(REPO / "motions" / "tonypi", tmp_path / "tonypi")
    auto = tmp_path / "tonypi" / "dance.yaml"
    auto.write_text(auto.read_text().replace("  bpm: 112\n", "  beats: auto\n"))
    written, detected = load_motion(DANCES[1]), load_motion(auto)
    assert detected.music.bpm is None and detected.music.grid.bar_one_beat == 1
    assert len(written.keyframes) == len(detected.keyframes)
    pairs = [(a.t_s, b.t_s) for a, b in zip(written.keyframes, detected.keyframes)]
    assert all((a is None) == (b is None) for a, b in pairs)
    times = np.array([pair for pair in pairs if pair[0] is not None])
    assert len(times) >= 16 and np.max(np.abs(times[:, 0] - times[:, 1])) <= 0.002


def test_a_mirrored_dance_keeps_its_song_and_times(tmp_path):
    source = load_motion(DANCES[0])
    out = tmp_path / "elsewhere" / "mirrored.yaml"
    out.parent.mkdir()
    assert main(["mirror", str(DANCES[0]), "-o", str(out)]) == 0
    mirrored = load_motion(out)
    assert mirrored.music.song.resolve() == source.music.song.resolve()
    assert (mirrored.music.start_s, mirrored.music.bpm) == (0.5, 112)
    assert [k.t_s for k in mirrored.keyframes] == [k.t_s for k in source.keyframes]


def test_a_beat_going_backwards_is_named_as_a_beat(tmp_path, song):
    path = write(
        tmp_path,
        "back.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
            bar: 2
          - pose: {shoulder: 20}
            beat: 3.5
        """,
    )
    assert problems_of(path) == [
        f"{path}:7:11: beat 3.5 (t 1.250) goes backwards: the keyframe before it ({path}:4:5) "
        "cannot be left before 2 s; t values must increase along the file"
    ]


def test_beats_auto_without_librosa_names_the_extra_at_the_line(tmp_path, song, monkeypatch):
    monkeypatch.setitem(sys.modules, "librosa", None)  # import librosa now raises ImportError
    path = write(
        tmp_path,
        "auto.yaml",
        """
        robot: arm6
        music:
          song: song.wav
          beats: auto
        keyframes:
          - pose: home
        """,
    )
    assert problems_of(path) == [
        f"{path}:4:10: beat detection needs librosa: install the music extra, pip install "
        "'choreo[music]'"
    ]


def test_the_schema_knows_the_music_block_and_beat_timing():
    schema = json.loads((REPO / "choreo" / "schema" / "motion.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    for path in DANCES:
        assert list(validator.iter_errors(yaml.safe_load(path.read_text()))) == []
    bad = {
        "robot": "arm6",
        "music": {"song": "a.ogg", "bpm": 120, "beats": "auto"},
        "keyframes": [{"pose": "home", "beat": 1, "t": 0}, {"pose": "home", "bar": 0}],
    }
    where = sorted(list(e.absolute_path) for e in validator.iter_errors(bad))
    assert where == [["keyframes", 0], ["keyframes", 1, "bar"], ["music"]]
    assert not validator.is_valid({"robot": "arm6", "music": {"song": "a.txt", "bpm": 1},
                                   "keyframes": [{"pose": "home"}]})  # fmt: skip


# --- beats: auto anchored where the author means; repeats; the song's end -------------------------
def test_beats_auto_takes_the_beat_nearest_start_and_says_so(tmp_path, capsys):
    times = steady_times(120, 0.253, 9.6)  # start: 0.26 is 7 ms after the first beat
    encode(click_track(times, 10.0), tmp_path / "clicks.wav")
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: clicks.wav, start: 0.26, beats: auto}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            bar: 2
        """,
    )
    assert main(["plan", str(path), "--json"]) == 0
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert np.array(report["keyframe_times_s"]) == pytest.approx(
        times[[0, 4]] - times[0], abs=0.015
    )
    assert report["music"]["start_s"] == pytest.approx(times[0], abs=0.015)  # moved onto beat 1
    assert "beat 1 is the beat detected at 0.25" in report["music"]["note"]
    assert "beat 1 is the beat detected at 0.25" in err


def test_beats_auto_counts_bars_from_the_downbeat_after_a_pickup(tmp_path, capsys):
    times = steady_times(120, 0.5, 9.6)
    encode(click_track(times, 10.0, first_accent=2), tmp_path / "pickup.wav")  # 2-beat pickup
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: pickup.wav, beats: auto}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            bar: 1
          - pose: {shoulder: -20}
            bar: 2
        """,
    )
    report = plan_json(capsys, path)
    # start 0 is more than half a beat before the first click: beat 1 is that click, at t 0.5
    assert report["music"]["beat_times_s"][0] == pytest.approx(times[0], abs=0.015)
    played = np.array(report["keyframe_times_s"])
    assert played == pytest.approx(times[[0, 2, 6]], abs=0.015)
    assert report["music"]["bar_one_beat"] == 3


def test_a_repeat_follows_the_songs_beats_as_it_speeds_up(tmp_path, capsys):
    intervals = np.linspace(0.6, 0.45, 30)  # an accelerando
    times = 0.5 + np.concatenate([[0], np.cumsum(intervals)])
    encode(click_track(times, times[-1] + 0.5), tmp_path / "faster.wav")
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        repeat: 3
        music: {song: faster.wav, start: 0.5, beats: auto, meter: 4/4}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            beat: 3
        """,
    )
    # a repetition lasts a bar (its last keyframe on beat 3): beats 1 3, 5 7, 9 11
    wanted = times[[0, 2, 4, 6, 8, 10]] - times[0]
    got = np.array(plan_json(capsys, path)["keyframe_times_s"])
    assert got == pytest.approx(wanted, abs=0.015)


def test_a_dance_past_its_song_is_refused_unless_allowed(tmp_path, song, capsys):
    text = """
        robot: arm6
        repeat: 3
        music: {song: song.wav, start: 0.5, bpm: 120}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            beat: 9
        """
    path = write(tmp_path, "long.yaml", text)
    # a repetition is 3 bars (beat 9 is in bar 3): the third ends on beat 33, the song at beat 19
    problem = (
        f"{path}:2:1: the dance (repeat 3) runs to at least t 16.000 s, 6.500 s past the end of "
        "song.wav (which ends at t 9.500 after start 0.5 s); end it sooner, start earlier in "
        "the song, or pass {} to dance on in silence"
    )
    # the library names its own argument; the command line, its flag
    assert problems_of(path) == [problem.format("allow_past_song")]
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == "choreo: error: " + problem.format("--allow-past-song")
    assert main(["validate", "--no-physics", str(path)]) == 1
    assert capsys.readouterr().out.splitlines()[0] == problem.format("--allow-past-song")
    assert main(["plan", str(path), "--allow-past-song"]) == 0
    assert "the dance goes on in silence" in capsys.readouterr().err
    once = write(tmp_path, "once.yaml", text.replace("repeat: 3", "repeat: 1"))
    assert main(["play", str(once), "--loop", "3", "--dry-run", "--no-audio"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --loop 3: the dance (repeat 3) runs to at least t 16.000 s, 6.500 s past "
        "the end of song.wav (which ends at t 9.500 after start 0.5 s); loop fewer times, or "
        "pass --allow-past-song to dance on in silence"
    )
    with pytest.raises(OptionError) as refused:  # the library names its own argument
        play_motion(once, port="sim://?ids=1-6&clock=virtual", options=PlayOptions(loop=3))
    assert (refused.value.option, refused.value.mentions) == ("loop", ("allow_past_song",))
    assert refused.value.problem.endswith(
        "loop fewer times, or pass allow_past_song to dance on in silence"
    )
    late = write(
        tmp_path,
        "late.yaml",
        text.replace("start: 0.5", "start: 9")
        .replace("repeat: 3", "repeat: 1")
        .replace("beat: 9", "t: 2"),
    )
    assert "runs to at least t 2.000 s, 1.000 s past the end" in problems_of(late)[0]


def test_an_empty_song_without_start_is_one_line(tmp_path):
    encode(Audio(np.zeros(0, np.float32), 22050), tmp_path / "empty.wav")
    path = write(
        tmp_path,
        "mute.yaml",
        "robot: arm6\nmusic: {song: empty.wav, bpm: 120}\nkeyframes:\n  - pose: home\n",
    )
    assert problems_of(path) == [f"{path}:2:15: empty.wav has no sound (0.000 s long); give a song"]


def test_a_bad_music_block_is_the_only_message_for_its_beats(tmp_path, song):
    path = write(
        tmp_path,
        "bad.yaml",
        """
        robot: arm6
        music: {song: song.wav, bpm: 120, meter: four}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            bar: 2
        """,
    )
    assert problems_of(path) == [
        f"{path}:2:42: meter 'four' is not a time signature; write it like 4/4, 3/4 or 6/8"
    ]


def test_the_music_example_of_the_docs_loads(tmp_path):
    docs = (REPO / "docs" / "motion-format.md").read_text()
    section = docs[docs.index("## Music: dancing on the beat") :]
    example = section[section.index("```yaml\n") + 8 : section.index("```\n", 10)]
    (tmp_path / "songs").mkdir()
    (tmp_path / "songs" / "groove.ogg").write_bytes(
        (REPO / "motions/songs/groove.ogg").read_bytes()
    )
    (tmp_path / "tonypi").mkdir()
    motion = load_motion(write(tmp_path / "tonypi", "dance.yaml", example))
    assert [k.t_s for k in motion.keyframes] == pytest.approx([0, 1.5, 8, 10] * np.array(60 / 112))


def test_the_music_block_takes_the_alternative_grid_with_beats_auto_only(tmp_path, song, capsys):
    path = write(
        tmp_path,
        "offbeat.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 0.7, beats: auto, offset_beats: 0.5, meter: 4/4}
        keyframes:
          - pose: home
            beat: 1
          - pose: {shoulder: 20}
            beat: 3
        """,
    )
    report = plan_json(capsys, path)  # the clicks are at 0.5, 1.0, ...: the off-beats 0.75, ...
    assert report["music"]["start_s"] == pytest.approx(0.75, abs=0.015)
    assert report["keyframe_times_s"] == pytest.approx([0.0, 1.0], abs=0.015)
    fixed = write(
        tmp_path,
        "fixed.yaml",
        "robot: arm6\nmusic: {song: song.wav, bpm: 120, level: half}\nkeyframes:\n  - pose: home\n",
    )
    assert problems_of(fixed) == [f"{fixed}:2:35: level goes with beats: auto, not bpm"]


def test_beats_auto_takes_the_next_downbeat_when_the_nearest_is_before_beat_1(tmp_path, capsys):
    times = steady_times(120, 0.5, 9.6)
    encode(click_track(times, 10.0), tmp_path / "bars.wav")  # accents on clicks 0, 4, 8...
    path = write(
        tmp_path,
        "dance.yaml",
        f"""
        robot: arm6
        music: {{song: bars.wav, start: {times[1]:.3f}, beats: auto}}
        keyframes:
          - pose: home
            beat: 1
          - pose: {{shoulder: 20}}
            bar: 1
          - pose: {{shoulder: -20}}
            bar: 2
        """,
    )
    report = plan_json(capsys, path)  # the downbeat nearest beat 1 (click 1) is click 0, before it
    assert report["music"]["bar_one_beat"] == 4
    played = np.array(report["keyframe_times_s"]) + times[1]
    assert played == pytest.approx(times[[1, 4, 8]], abs=0.015)


def test_a_song_of_nan_samples_is_one_line_at_its_beats(tmp_path):
    import scipy.io.wavfile

    samples = click_track(steady_times(120, 0.5, 9.6), 10.0).samples.copy()
    samples[22050 * 3] = np.nan
    scipy.io.wavfile.write(tmp_path / "broken.wav", 22050, samples)
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: broken.wav, beats: auto}
        keyframes:
          - pose: home
            beat: 1
        """,
    )
    (problem,) = problems_of(path)
    assert problem.startswith(f"{path}:2:")
    assert "samples that are not numbers (NaN or infinite), the first at 3.000 s" in problem


def test_an_offset_beyond_four_bars_is_refused_at_its_place(tmp_path, song):
    path = write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: song.wav, beats: auto, offset_beats: 1.0e+308}
        keyframes:
          - pose: home
            beat: 1
        """,
    )
    (problem,) = problems_of(path)
    assert problem.startswith(f"{path}:2:")
    assert problem.endswith("offset_beats must be in -16..16 beats, got 1e+308")
