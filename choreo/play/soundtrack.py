"""The song beside the servos: audio outputs ("sinks") and playing a performance with its song.

A sink is told, once, to make song time ``from_s`` sound at clock time ``sound_at_s`` - the
player's first START - and works out the rest itself: it starts its stream early, with silence,
so that its output latency is spent before that moment (or, if called too late, skips into the
song so the sound is still in sync). Like the clock, the sink is injected: tests use a
``RecordingSink`` in virtual time; ``choreo play`` a ``SoundDeviceSink`` (the ``choreo[music]``
extra, imported only here, only when used).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from choreo.core.clock import Clock
from choreo.errors import NoAudioOutput
from choreo.motion.music_block import Music
from choreo.music.decode import Audio, decode_song
from choreo.plan.performance import Performance
from choreo.play.player import Player
from choreo.play.report import StreamReport

log = logging.getLogger(__name__)

OUTPUT_RATE_HZ = 44100


class AudioSink(Protocol):
    latency_s: float  # from a sample handed over to it sounding

    def play(self, audio: Audio, from_s: float, sound_at_s: float) -> None:
        """Sound song time ``from_s`` at clock time ``sound_at_s`` (before 0: silence first)."""

    def stop(self) -> None:
        """Silence at once; harmless when not playing or stopped already."""


@dataclass(frozen=True)
class SongCue:
    """When the song starts: song time ``from_s`` at the first START of the performance."""

    song_name: str
    from_s: float  # may be negative: the song begins that much after the first START

    @staticmethod
    def of(music: Music, performance: Performance) -> SongCue:
        # The motion's t=0 comes after the approach: the song's ``start`` must sound then.
        return SongCue(music.song.name, music.start_s - performance.approach_s)

    def describe(self) -> str:
        if self.from_s >= 0:
            return f"song {self.song_name} starts at the first START, from {self.from_s:.3f} s in"
        return f"song {self.song_name} starts {-self.from_s * 1000:.0f} ms after the first START"


def play_with_song(
    player: Player,
    performance: Performance,
    start_pose_deg: Sequence[float],
    sink: AudioSink | None,
    audio: Audio | None,
    cue: SongCue | None,
) -> StreamReport:
    """Play ``performance`` with the song cued on the first START; every way out (the end,
    Ctrl-C, SIGTERM, an abort, an error) stops the song too."""
    if sink is None or audio is None or cue is None:
        return player.play(performance.ticks, start_pose_deg)
    previous = player.on_first_start
    player.on_first_start = lambda t0_s: sink.play(audio, cue.from_s, t0_s)
    try:
        return player.play(performance.ticks, start_pose_deg)
    finally:
        sink.stop()
        player.on_first_start = previous


def song_for_output(music: Music) -> Audio:
    return decode_song(music.song, rate_hz=OUTPUT_RATE_HZ, channels=2)


# --- a sink that records (tests, dry runs, benchmarks) -----------------------------------------
class RecordingSink:
    """Plays nothing; records on ``clock`` when the song would sound and when it stopped, as an
    output with ``latency_s`` would: started when ``play`` is called, padded with silence."""

    def __init__(self, clock: Clock, latency_s: float = 0.0):
        self.clock, self.latency_s = clock, latency_s
        self.sounds_at_s: float | None = None  # clock time the first song sample sounds
        self.sounds_from_s: float | None = None  # song time of that sample
        self.stopped_at_s: float | None = None

    def play(self, audio: Audio, from_s: float, sound_at_s: float) -> None:
        first_out_s = self.clock.now() + self.latency_s  # the earliest anything can sound
        late_s = max(0.0, first_out_s - sound_at_s)
        self.sounds_at_s = sound_at_s + late_s + max(0.0, -(from_s + late_s))
        self.sounds_from_s = max(from_s + late_s, 0.0)

    def song_time_at(self, clock_s: float) -> float | None:
        if self.sounds_at_s is None or self.sounds_from_s is None:
            return None
        return self.sounds_from_s + clock_s - self.sounds_at_s

    def stop(self) -> None:
        if self.stopped_at_s is None:
            self.stopped_at_s = self.clock.now()


# --- the real one: PortAudio through sounddevice -----------------------------------------------
class SoundDeviceSink:
    """An output stream that runs (silent) from construction; ``play`` maps the clock onto the
    stream's own time line and the callback puts each song sample where it must sound.

    Clock times are ``time.monotonic`` (the player's ``RealClock``)."""

    def __init__(self, device: str | int | None = None, latency_s: float | None = None):
        sd = _import_sounddevice()
        self._lock = threading.Lock()
        self._song: np.ndarray | None = None
        self._first_dac_s = 0.0  # stream time at which song sample 0 sounds
        try:
            self._stream = sd.OutputStream(
                samplerate=OUTPUT_RATE_HZ,
                channels=2,
                dtype="float32",
                device=device,
                latency="low",
                callback=self._fill,
            )
            self._stream.start()
        except Exception as error:  # PortAudioError, ValueError for an unknown device
            raise NoAudioOutput(
                f"cannot open audio output {device or '(default)'}: {error}"
            ) from None
        reported = float(self._stream.latency)
        self.latency_s = reported if latency_s is None else latency_s
        self._correction_s = self.latency_s - reported  # what the device's figure gets wrong
        self._clock_to_stream_s = self._stream.time - time.monotonic()

    def play(self, audio: Audio, from_s: float, sound_at_s: float) -> None:
        if audio.rate_hz != OUTPUT_RATE_HZ or audio.samples.ndim != 2:
            raise ValueError("decode the song with song_for_output() first")
        with self._lock:
            self._song = audio.samples
            # sample 0 sounds from_s before sound_at_s; the callback's DAC times are the
            # device's figure, corrected by the user's
            self._first_dac_s = sound_at_s + self._clock_to_stream_s - from_s - self._correction_s

    def _fill(self, out, frames, timing, status) -> None:
        out.fill(0)
        with self._lock:
            song, first = self._song, self._first_dac_s
        if song is None:
            return
        dac_s = timing.outputBufferDacTime or (timing.currentTime + self._stream.latency)
        begin = int(round((dac_s - first) * OUTPUT_RATE_HZ))
        low, high = max(begin, 0), min(begin + frames, len(song))
        if high > low:
            out[low - begin : high - begin] = song[low:high]

    def stop(self) -> None:
        with self._lock:
            self._song = None
        try:
            self._stream.abort()  # at once: stop() would play out what is queued first
            self._stream.close()
        except Exception as error:  # the device went away: nothing left to silence
            log.info("closing the audio stream: %s", error)


def _import_sounddevice():
    try:
        import sounddevice
    except ImportError:
        raise NoAudioOutput("sounddevice is not installed (pip install 'choreo[music]')") from None
    except OSError as error:  # the package is there, the PortAudio library is not
        raise NoAudioOutput(
            f"{error} (install PortAudio, e.g. apt install libportaudio2)"
        ) from None
    return sounddevice
