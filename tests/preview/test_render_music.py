"""The preview video carries the song (read back from the file), and frames show bar and beat.

Named to run after test_render.py, whose back-end tests need a process that has not rendered yet."""

from __future__ import annotations

import re
import subprocess

import imageio_ffmpeg
import numpy as np
import pytest
from music_helpers import first_click_s, steady_times, write, write_clicks
from PIL import Image

from choreo.cli import main
from choreo.motion.motion_file import Motion, load_motion
from choreo.preview import RenderSettings, SimulatedMotion, render_preview, simulate_motion
from choreo.preview.render import status_text

RATE_HZ = 22050


@pytest.fixture(scope="module")
def dance(tmp_path_factory):
    # clicks from 1.0 s; the dance starts 0.8 s into the song: the video's first click is at 0.2 s
    folder = tmp_path_factory.mktemp("dance")
    write_clicks(folder / "song.ogg", steady_times(120, 1.0, 7.0), 7.5)
    return write(
        folder,
        "dance.yaml",
        """
        robot: arm6
        music: {song: song.ogg, start: 0.8, bpm: 120}
        keyframes:
          - pose: home
          - pose: {shoulder: 30}
            beat: 3
          - pose: home
            bar: 2
        """,
    )


@pytest.fixture(scope="module")
def motion(dance) -> Motion:
    return load_motion(dance)


@pytest.fixture(scope="module")
def simulated(motion) -> SimulatedMotion:
    """The dance simulated once, for the tests that only read it."""
    return simulate_motion(motion)


def streams_of(path) -> str:
    """ffmpeg's own description of the file's streams (it exits 1: no output given)."""
    probe = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)],
        capture_output=True,
        text=True,
    )
    return probe.stderr


def audio_of(path) -> np.ndarray:
    command = [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path), "-map", "0:a"]
    command += ["-f", "f32le", "-ac", "1", "-ar", str(RATE_HZ), "-"]
    return np.frombuffer(subprocess.run(command, capture_output=True, check=True).stdout, "<f4")


def test_the_mp4_carries_the_song_from_its_start(dance, simulated, tmp_path, capsys):
    video = tmp_path / "dance.mp4"
    assert main(["preview", str(dance), "-o", str(video), "--size", "64x48", "--fps", "10"]) == 0
    streams = streams_of(video)
    assert re.search(r"Stream #0:\d.*: Video: h264", streams)
    assert re.search(r"Stream #0:\d.*: Audio: aac", streams)
    frames = int(re.search(r"wrote .* \((\d+) frames", capsys.readouterr().out).group(1))
    video_s = frames / 10
    audio = audio_of(video)
    assert abs(len(audio) / RATE_HZ - video_s) <= 0.05  # the track lasts as long as the video
    # the video opens with the settling and the approach (rollout.start_s before t=0); the
    # song's 0.8 s is heard at t=0, so its first click (at 1.0 s) 0.2 s after
    before_s = -simulated.rollout.start_s
    assert before_s > 0
    assert first_click_s(audio, RATE_HZ) == pytest.approx(before_s + 0.2, abs=0.01)
    assert not list(tmp_path.glob(".*.mp4"))  # the intermediate file is gone


def test_frames_show_the_bar_and_beat(motion, simulated):
    rollout = simulated.rollout
    grid = motion.music.grid
    names, values = status_text(rollout, 0.0, grid)
    assert names.splitlines()[-1] == "bar / beat" and values.splitlines()[-1] == "1 / 1"
    _, values = status_text(rollout, 2.74, grid)  # beat 6.48: bar 2, beat 2
    assert values.splitlines()[-1] == "2 / 2"
    names, _ = status_text(rollout, 1.0)
    assert "bar" not in names


def test_before_the_first_beat_frames_count_in(motion, simulated):
    """Settling and the approach come before beat 1 (the beats are not clamped to "1 / 1"):
    the overlay counts the beats still to come, at the first beats' interval."""
    rollout = simulated.rollout
    grid = motion.music.grid
    first, interval = grid.beat_times_s[0], grid.beat_times_s[1] - grid.beat_times_s[0]
    names, values = status_text(rollout, first - 2.5 * interval, grid)
    assert names.splitlines()[-1] == "count-in" and values.splitlines()[-1] == "3"
    _, values = status_text(rollout, first - 0.5 * interval, grid)
    assert values.splitlines()[-1] == "1"
    names, values = status_text(rollout, rollout.start_s, grid)
    assert names.splitlines()[-1] == "count-in" and int(values.splitlines()[-1]) >= 1


def test_a_contact_sheet_marks_each_frames_beat(motion, simulated, tmp_path):
    settings = RenderSettings(width=160, height=120, sheet_frames=4)
    marked = render_preview(simulated, tmp_path / "marked.png", settings, music=motion.music)
    plain = render_preview(simulated.rollout, tmp_path / "plain.png", settings)
    with_beats = np.asarray(Image.open(marked.path).convert("L"), dtype=int)
    without = np.asarray(Image.open(plain.path).convert("L"), dtype=int)
    assert with_beats.shape == without.shape
    changed_rows = np.flatnonzero(np.abs(with_beats - without).max(axis=1) > 64)
    # the bar / beat line is drawn below the other overlay lines of each tile's top-left
    assert len(changed_rows) > 0 and changed_rows.min() < 120


def test_a_video_with_the_song_refuses_another_speed(dance, tmp_path, capsys):
    video = tmp_path / "fast.mp4"
    assert main(["preview", str(dance), "-o", str(video), "--speed", "2"]) == 2  # an option
    assert "choreo: error: --speed 2 would leave song.ogg behind" in capsys.readouterr().err
    assert not video.exists()
