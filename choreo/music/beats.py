"""Beat detection: tempo, beat and downbeat times of a song (``choreo beats``, ``beats: auto``).

librosa (the ``choreo[music]`` extra, imported only here) tracks the beats on a coarse onset
envelope; each beat is then moved onto the sharpest onset within ``SNAP_S`` of it, found on a
fine envelope (3 ms frames), so beats are as precise as the attacks in the song. Tempi come from
the beat times themselves (a least-squares line through each steady stretch), not from the
tracker's tempo bins. Downbeats are every ``beats_per_bar``-th beat, in the phase whose beats are
the loudest (bars start with an accent: RMS over ``ACCENT_S`` from each beat).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.errors import ChoreoError
from choreo.music.decode import Audio

COARSE_HOP = 512  # ~23 ms frames at 22050 Hz: what the tracker is tuned for
FINE_HOP = 64  # ~3 ms frames: where beats are snapped to
SNAP_S = 0.05  # a beat moves at most this far onto an onset
ACCENT_S = 0.05  # a beat's loudness: the RMS of this much sound from it
TEMPO_CHANGE = 0.04  # a beat interval this much off the running one starts a new tempo


@dataclass(frozen=True)
class TempoSpan:
    start_s: float  # song time of the span's first beat
    end_s: float  # song time of its last beat
    bpm: float


@dataclass(frozen=True)
class BeatAnalysis:
    duration_s: float
    beats_s: tuple[float, ...]  # song times
    downbeats_s: tuple[float, ...]
    beats_per_bar: int
    tempi: tuple[TempoSpan, ...]  # steady stretches, in order

    @property
    def bpm(self) -> float:
        """The tempo of the longest steady stretch (0 with fewer than two beats)."""
        if not self.tempi:
            return 0.0
        return max(self.tempi, key=lambda span: span.end_s - span.start_s).bpm


def require_librosa():
    try:
        import librosa
    except ImportError:
        raise ChoreoError(
            "beat detection needs librosa: install the music extra, pip install 'choreo[music]'"
        ) from None
    return librosa


def detect_beats(audio: Audio, beats_per_bar: int = 4) -> BeatAnalysis:
    if beats_per_bar < 1:
        raise ValueError(f"beats_per_bar must be >= 1, got {beats_per_bar}")
    librosa = require_librosa()
    y, sr = np.asarray(audio.mono, dtype=np.float32), audio.rate_hz
    if len(y) < sr // 2 or not np.any(y):
        return BeatAnalysis(audio.duration_s, (), (), beats_per_bar, ())
    coarse = librosa.onset.onset_strength(y=y, sr=sr, hop_length=COARSE_HOP)
    _, frames = librosa.beat.beat_track(
        onset_envelope=coarse, sr=sr, hop_length=COARSE_HOP, trim=False
    )
    tracked = librosa.frames_to_time(frames, sr=sr, hop_length=COARSE_HOP)
    # A click right at the start has no frame before it to rise from: pad so it has one.
    pad = FINE_HOP * 4
    fine = librosa.onset.onset_strength(
        y=np.concatenate([np.zeros(pad, np.float32), y]), sr=sr, hop_length=FINE_HOP, n_fft=512
    )[4:]
    beats = _extend(
        _snap(np.asarray(tracked, dtype=float), fine, sr / FINE_HOP), fine, sr / FINE_HOP
    )
    downbeats = beats[_downbeat_phase(beats, y, sr, beats_per_bar) :: beats_per_bar]
    return BeatAnalysis(
        audio.duration_s,
        tuple(float(b) for b in beats),
        tuple(float(b) for b in downbeats),
        beats_per_bar,
        _tempo_spans(beats),
    )


def _snap(beats: np.ndarray, envelope: np.ndarray, frame_rate: float) -> np.ndarray:
    """Each beat moved to the strongest onset within SNAP_S, if there is one; beats with no onset
    near them at either end (the tracker fills silence at the start and end) are left out."""
    reach = int(round(SNAP_S * frame_rate))
    snapped, strength = [], []
    for beat in beats:
        centre = int(round(beat * frame_rate))
        low, high = max(centre - reach, 0), min(centre + reach + 1, len(envelope))
        frame = low + int(np.argmax(envelope[low:high])) if high > low else centre
        peak = float(envelope[frame]) if high > low else 0.0
        snapped.append(frame / frame_rate if peak > 0 else beat)
        strength.append(peak)
    strength_arr = np.asarray(strength)
    strong = np.flatnonzero(strength_arr >= 0.3 * np.median(strength_arr))
    if len(strong) == 0:
        return np.asarray([])
    kept = np.asarray(snapped[strong[0] : strong[-1] + 1])
    return np.unique(np.round(kept, 6))


def _extend(beats: np.ndarray, envelope: np.ndarray, frame_rate: float) -> np.ndarray:
    """Beats the tracker left out at either end: one period further, while an onset is there
    (at least half a period further, so the search always moves on)."""
    if len(beats) < 4:
        return beats
    threshold = 0.5 * np.median(envelope[np.round(beats * frame_rate).astype(int)])
    times = [float(b) for b in beats]
    period = float(np.median(np.diff(beats[:4])))
    while (found := _onset_near(times[0] - period, envelope, frame_rate, threshold)) is not None:
        if found > times[0] - period / 2:
            break
        times.insert(0, found)
    period = float(np.median(np.diff(beats[-4:])))
    while (found := _onset_near(times[-1] + period, envelope, frame_rate, threshold)) is not None:
        if found < times[-1] + period / 2:
            break
        times.append(found)
    return np.asarray(times)


def _onset_near(t_s: float, envelope: np.ndarray, frame_rate: float, threshold: float):
    reach = int(round(SNAP_S * frame_rate))
    centre = int(round(t_s * frame_rate))
    low, high = max(centre - reach, 0), min(centre + reach + 1, len(envelope))
    if high - low <= reach:  # the window falls off the song
        return None
    frame = low + int(np.argmax(envelope[low:high]))
    return frame / frame_rate if envelope[frame] >= threshold else None


def _downbeat_phase(beats: np.ndarray, y: np.ndarray, rate_hz: int, per_bar: int) -> int:
    """The phase (0..per_bar-1) of the beats that are loudest on average: the bars' accents."""
    if len(beats) < per_bar:
        return 0
    window = int(ACCENT_S * rate_hz)
    loudness = np.array(
        [
            np.sqrt(np.mean(np.square(y[i : i + window]))) if i < len(y) else 0.0
            for i in (np.round(beats * rate_hz).astype(int))
        ]
    )
    return int(np.argmax([loudness[phase::per_bar].mean() for phase in range(per_bar)]))


def _tempo_spans(beats: np.ndarray) -> tuple[TempoSpan, ...]:
    """Split the beats where the interval changes for good; a line through each stretch."""
    if len(beats) < 2:
        return ()
    intervals = np.diff(beats)
    starts = [0]
    for i in range(1, len(intervals)):
        reference = np.median(intervals[starts[-1] : i])
        upcoming = np.median(intervals[i : i + 3])  # a lasting change, not one odd beat
        if abs(upcoming - reference) > TEMPO_CHANGE * reference:
            starts.append(i)
    spans = []
    for first, stop in zip(starts, starts[1:] + [len(intervals)]):
        stretch = beats[first : stop + 1]
        if len(stretch) < 3 and len(starts) > 1:
            continue  # one interval between two tempi: the change itself
        slope = np.polyfit(np.arange(len(stretch)), stretch, 1)[0]
        spans.append(TempoSpan(float(stretch[0]), float(stretch[-1]), 60.0 / float(slope)))
    return tuple(spans)
