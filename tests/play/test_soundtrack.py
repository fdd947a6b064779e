"""The song beside the servos: cued on the first START on the wire, stopped with the servos."""

from __future__ import annotations

import re
import sys
import time
import types

import numpy as np
import pytest
from music_helpers import steady_times, write, write_clicks
from play_helpers import Rig

from choreo.bus.protocol import Command
from choreo.cli import main, play_commands
from choreo.core.clock import VirtualClock
from choreo.music.decode import Audio
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import preflight
from choreo.play.report import Outcome
from choreo.play.soundtrack import (
    OUTPUT_RATE_HZ,
    NoAudioOutput,
    RecordingSink,
    SongCue,
    SoundDeviceSink,
    play_with_song,
)

SAME_TIME_S = 0.002
LATENCY_S = 0.08


@pytest.fixture
def dance(tmp_path):
    write_clicks(tmp_path / "song.wav", steady_times(120, 1.0, 11.0), 11.5)
    return write(
        tmp_path,
        "dance.yaml",
        """
        robot: arm6
        music: {song: song.wav, start: 1.0, bpm: 120}
        keyframes:
          - pose: {shoulder: 10}
            beat: 1
          - pose: {shoulder: 30, base_yaw: 20}
            beat: 3
          - pose: {shoulder: -20, base_yaw: -20}
            beat: 5
          - pose: home
            bar: 3
        """,
    )


def play_in_virtual_time(path, on_progress=None):
    rig = Rig(str(path))
    start, limits = preflight(rig.bus, rig.robot)
    performance = prepare(compile_motion(rig.motion), start)
    sink = RecordingSink(rig.clock, latency_s=LATENCY_S)
    options = PlayOptions(lead_s=LATENCY_S + 0.05)  # what choreo play asks for with a song
    player = Player(rig.bus, rig.robot, rig.clock, limits, options, on_progress)
    cue = SongCue.of(rig.motion.music, performance)
    report = play_with_song(player, performance, start, sink, object(), cue)
    return rig, performance, sink, report


def test_the_song_sounds_with_the_first_start_on_the_wire(dance):
    rig, performance, sink, report = play_in_virtual_time(dance)
    assert report.outcome is Outcome.COMPLETED
    starts = rig.packets(Command.MOVE_START)
    assert abs(sink.sounds_at_s - starts[0].time_s) <= SAME_TIME_S
    # the motion's t=0 (after the approach) hears the song's start: 1.0 s in
    motion_t0 = starts[0].time_s + performance.approach_s
    assert sink.song_time_at(motion_t0) == pytest.approx(1.0, abs=SAME_TIME_S)
    assert sink.stopped_at_s is not None and sink.stopped_at_s >= report.start_time_s


def test_ctrl_c_stops_the_song_and_the_servos_together(dance):
    def interrupt(progress):
        if progress.tick == 5:
            raise KeyboardInterrupt

    rig, _, sink, report = play_in_virtual_time(dance, interrupt)
    assert report.outcome is Outcome.INTERRUPTED
    stop = rig.packets(Command.MOVE_STOP)[0]
    assert sink.stopped_at_s is not None
    assert abs(sink.stopped_at_s - stop.time_s) <= SAME_TIME_S


def test_a_late_cue_skips_into_the_song_to_stay_in_sync():
    clock = VirtualClock(10.0)
    sink = RecordingSink(clock, latency_s=0.1)
    sink.play(object(), from_s=2.0, sound_at_s=10.03)  # 70 ms too late for this output
    assert sink.sounds_at_s == pytest.approx(10.1)
    assert sink.song_time_at(10.03) == pytest.approx(2.0)


def test_dry_run_says_when_the_song_starts(dance, capsys):
    assert main(["play", str(dance), "--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    song = [line for line in lines if "song song.wav" in line]
    assert len(song) == 1
    assert re.fullmatch(
        r" +0 ms  song song.wav starts at the first START, from ([\d.]+) s in", song[0]
    )
    start_tick = next(i for i, line in enumerate(lines) if "START tick 0" in line)
    assert lines.index(song[0]) > start_tick


def test_play_without_an_audio_output_says_so_once_and_dances(
    dance, capsys, monkeypatch, virtual_built_in_emulator
):
    def no_output(device, latency_s):
        raise NoAudioOutput("cannot open audio output (default): no device")

    monkeypatch.setattr(play_commands, "open_audio_output", no_output)
    assert main(["play", str(dance)]) == 0
    err = capsys.readouterr().err
    assert (
        "choreo: no audio output: cannot open audio output (default): no device; playing "
        "without the music\n"
    ) in err


def test_play_plays_the_song_on_the_output_and_stops_it(
    dance, capsys, monkeypatch, virtual_built_in_emulator
):
    sinks = []

    def recording(device, latency_s):  # on the clock of the bus it plays beside
        clock = virtual_built_in_emulator[-1].clock
        sinks.append(RecordingSink(clock, latency_s=latency_s or 0.0))
        sinks[-1].device = device
        return sinks[-1]

    monkeypatch.setattr(play_commands, "open_audio_output", recording)
    assert main(["play", str(dance), "--audio-device", "hw:1", "--audio-latency-ms", "40"]) == 0
    (sink,) = sinks
    assert sink.device == "hw:1" and sink.latency_s == pytest.approx(0.04)
    assert sink.sounds_at_s is not None and sink.stopped_at_s > sink.sounds_at_s
    assert main(["play", str(dance), "--no-audio"]) == 0
    assert len(sinks) == 1


class FakeOutputStream:
    """sounddevice.OutputStream's part the sink uses: its own time line 100 s ahead of the
    monotonic clock, a reported latency of 50 ms, and a callback the test calls."""

    latency = 0.05

    def __init__(self, callback, **settings):
        self.callback, self.settings = callback, settings
        self.active = False

    @property
    def time(self):
        return time.monotonic() + 100.0

    def start(self):
        self.active = True

    def abort(self):
        self.active = False

    def close(self):
        pass


@pytest.fixture
def fake_sounddevice(monkeypatch):
    module = types.SimpleNamespace(OutputStream=FakeOutputStream)
    monkeypatch.setitem(sys.modules, "sounddevice", module)
    return module


def played_song_time(sink, song, dac_s: float) -> float:
    """Which song time the sink's callback puts first in a buffer that sounds at ``dac_s``."""
    out = np.zeros((64, 2), np.float32)
    timing = types.SimpleNamespace(outputBufferDacTime=dac_s, currentTime=0.0)
    sink._stream.callback(out, 64, timing, None)
    assert np.any(out), "the buffer is silent"
    return float(out[0, 0])  # the test song's samples are their own times


@pytest.mark.parametrize(("latency_ms", "correction_s"), [(None, 0.0), (80.0, 0.03)])
def test_the_real_sink_puts_the_cued_sample_where_it_sounds_on_time(
    fake_sounddevice, latency_ms, correction_s
):
    sink = SoundDeviceSink("hw:1", None if latency_ms is None else latency_ms / 1000)
    assert sink._stream.settings["device"] == "hw:1" and sink._stream.active
    assert sink.latency_s == pytest.approx(0.05 if latency_ms is None else 0.08)
    times = np.arange(5 * OUTPUT_RATE_HZ, dtype=np.float32) / OUTPUT_RATE_HZ
    song = Audio(np.stack([times, times], axis=1), OUTPUT_RATE_HZ)
    sink.play(song, from_s=1.0, sound_at_s=50.0)
    # a buffer the device says sounds at clock 50 s (stream 150 s) really sounds correction later
    assert played_song_time(sink, song, 150.0 - correction_s) == pytest.approx(1.0, abs=1e-3)
    assert played_song_time(sink, song, 150.5 - correction_s) == pytest.approx(1.5, abs=1e-3)
    sink.stop()
    assert not sink._stream.active


def test_a_speed_that_would_leave_the_song_behind_is_refused(dance, capsys):
    assert main(["play", str(dance), "--speed", "1.5", "--dry-run"]) == 2
    assert capsys.readouterr().err == (
        "choreo: error: --speed 1.5 would leave song.wav behind (the song plays at its own "
        "tempo); keep --speed 1 with a song\n"
    )
    assert main(["play", str(dance), "--speed", "0.5", "--dry-run", "--no-audio"]) == 0
    out = capsys.readouterr().out
    assert "song" not in out
