"""Beat detection: tempo, beat and downbeat times of a song (``choreo beats``, ``beats: auto``).

Built on librosa's features (the ``choreo[music]`` extra, imported only here; the downbeat
trackers on PyPI need torch or no longer build, see the docs):

- **Beats** follow the local tempo (:mod:`~choreo.music.tempo`: librosa's tempogram, each
  frame folded onto the song's dominant level, smoothed); a song whose local tempo is steady is
  tracked at one tempo, any other with the tempo changing along the song (librosa's
  dynamic-programming tracker, :mod:`~choreo.music.tracker`, takes a tempo per frame). The
  tracker runs on the onset envelope with its low band (kick, bass) counted twice, so loud
  off-beat stabs don't pull the grid off.
  Each beat is then moved onto the sharpest onset within ``SNAP_S`` (3 ms frames), so beats are
  as precise as the attacks in the song. Tempi come from the beat times (a line through each
  steady stretch).
- **Downbeats and meter**: :mod:`~choreo.music.bars` (meters 2 to 7, compound and additive ones
  told as such, downbeats decoded as a path that may restart).
- **Confidence**: the autocorrelation, at the beat period, of the onset envelope with its slow
  swells removed (0 for noise, near 1 for a metronome), per stretch. Below ``STEADY_CONFIDENCE``
  the song has no steady beat.

The envelopes come from :mod:`~choreo.music.features`, a block at a time.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from choreo.core.arguments import (
    COUNT,
    Range,
    check_choice,
    check_number,
    check_optional_number,
    check_path,
)
from choreo.errors import ChoreoError, Worded
from choreo.music.bars import GAP, find_bars
from choreo.music.decode import Audio, decode_song
from choreo.music.features import Features, around, normalised, song_features
from choreo.music.tempo import local_tempo
from choreo.music.tracker import track_beats

SNAP_S = 0.05  # a beat moves at most this far onto an onset
TEMPO_CHANGE = 0.04  # a beat interval this much off the running one starts a new tempo
STEADY_CONFIDENCE = 0.2  # below this there is no steady beat
OFFBEAT_RATIO = 0.5  # onsets between the beats this strong against on them: maybe off-beat
SILENT = 0.02  # a beat this much quieter than the song's typical one is in a silence
BACKBEAT = 0.25  # snares on even and odd beats within this of each other: on every beat
# the snare on every other midpoint this much stronger than on either half of the beats: the beats
# are on the off-beats (funk tracked off the beat: 1.7; songs on the beat: at most 0.93)
BACKBEAT_BETWEEN = 1.3
ODD_METER_BPM = 200.0  # 5 or 7 beats to the bar tracked at half tempo are doubled up to this
FAST_BPM, SLOW_BPM = 140.0, 70.0  # beyond these the felt beat is often half / twice the tracked
# the alternative grids: every other beat, a beat between each two, three beats in each (the
# eighths of a compound meter), every third beat
LEVELS = ("half", "double", "triple", "third")
GRID_OPTIONS = ("level", "offset_beats")  # detect_beats' arguments a warning offers
# librosa's features with the bars decoded here (the default: no torch), or Beat This! (the
# extra choreo[beats-neural]; not the default: its weights could not be fetched to measure it)
TRACKERS = ("librosa", "beat-this")
MIN_BEATS = 8  # fewer beats than this are no steady beat, however regular
OFFSET_BEATS = Range(at_least=-16, at_most=16, unit=" beats")  # up to four bars of 4/4 either way


@dataclass(frozen=True)
class TempoSpan:
    start_s: float  # song time of the span's first beat
    end_s: float  # song time of its last beat
    bpm: float
    confidence: float = 1.0  # 0..1: how clearly the onsets repeat at this beat period


@dataclass(frozen=True)
class BeatAnalysis:
    duration_s: float
    beats_s: tuple[float, ...]  # song times
    downbeats_s: tuple[float, ...]
    beats_per_bar: int
    tempi: tuple[TempoSpan, ...]  # steady stretches, in order
    meter_detected: bool = False  # beats_per_bar was estimated (no meter was given)
    meter_confidence: float = 1.0  # 0..1: how far the chosen meter's bars stand out
    subdivision: int = 2  # 3: each beat is three eighths (a compound meter: 6/8 has two beats)
    grouping: tuple[int, ...] = ()  # an additive meter's groups of beats: (2, 2, 3)
    # the grid may be off-beat, at half or double tempo (Worded: naming detect_beats' arguments)
    warnings: tuple[str, ...] = ()

    @property
    def meter(self) -> str:
        """The time signature: 4/4, 3/4, 6/8 (two beats of three eighths), 7/8 (2+2+3)..."""
        if self.subdivision == 3:
            return f"{3 * self.beats_per_bar}/8"
        fast = self.bpm >= (150 if self.beats_per_bar == 7 else 200)  # the beats are eighths
        return f"{self.beats_per_bar}/{8 if fast and self.grouping else 4}"

    @property
    def bpm(self) -> float:
        """The tempo of the longest steady stretch (0 with fewer than two beats)."""
        if not self.tempi:
            return 0.0
        return max(self.tempi, key=lambda span: span.end_s - span.start_s).bpm

    @property
    def confidence(self) -> float:
        """The stretches' confidence, weighted by their length (0 without beats)."""
        lengths = np.array([span.end_s - span.start_s for span in self.tempi])
        if not self.tempi or lengths.sum() <= 0:
            return 0.0
        return float(np.average([span.confidence for span in self.tempi], weights=lengths))

    @property
    def steady(self) -> bool:
        """Whether the song has a beat to dance to."""
        return self.unsteady_because is None

    @property
    def unsteady_because(self) -> str | None:
        """Why the song has no beat to dance to (one phrase), or None if it has one."""
        if not self.beats_s:
            return "no beats were found"
        if len(self.beats_s) < MIN_BEATS:
            return f"only {len(self.beats_s)} beats were found (a steady beat needs {MIN_BEATS})"
        if self.confidence < STEADY_CONFIDENCE:
            return (
                f"the beats found are not steady (confidence {self.confidence:.2f}, "
                f"below {STEADY_CONFIDENCE})"
            )
        return None

    @property
    def change_points_s(self) -> tuple[float, ...]:
        """Song times where a new tempo starts."""
        return tuple(span.start_s for span in self.tempi[1:])


def require_librosa():
    try:
        import librosa
    except ImportError:
        raise ChoreoError(
            "beat detection needs librosa: install the music extra, pip install 'choreo[music]'"
        ) from None
    return librosa


def detect_beats(
    audio: Audio | str | os.PathLike[str],
    beats_per_bar: int | None = None,
    level: str = "",
    offset_beats: float = 0.0,
    tracker: str = "librosa",
) -> BeatAnalysis:
    """The beats of a song: ``audio`` decoded (``decode_song``) or its file's path (wav, flac,
    ogg, mp3). ``beats_per_bar`` None: the meter is estimated. ``level`` (one of LEVELS) and
    ``offset_beats`` (in beats, e.g. 0.5: the off-beats) give the alternative grid a warning
    offers. ``tracker``: one of TRACKERS."""
    check_optional_number("beats_per_bar", beats_per_bar, COUNT)
    check_grid(level, offset_beats)
    check_choice("tracker", tracker, TRACKERS)
    if not isinstance(audio, Audio):
        audio = decode_song(check_path("audio", audio, "an Audio (decode_song) or a song's path"))
    librosa = require_librosa()
    y, sr = audio.mono, audio.rate_hz
    _check_samples(y, sr)
    if len(y) < sr // 2 or not np.any(y):
        return _no_beats(audio, beats_per_bar)
    features = song_features(librosa, np.asarray(y, dtype=np.float32), sr)
    if tracker == "beat-this":
        return _neural_analysis(audio, features, beats_per_bar, level, offset_beats)
    beats = _track(librosa, features)
    beats = _regrid(features, beats, level, offset_beats)
    if len(beats) == 0:
        return _no_beats(audio, beats_per_bar)
    bars = find_bars(features, beats, beats_per_bar)
    if _odd_bars_of_two_beats(features, beats, bars.beats_per_bar, beats_per_bar or level):
        beats = _track(librosa, features, scale=2.0)
        bars = find_bars(features, beats, beats_per_bar)
    spans = _tempo_spans(beats, features)
    return BeatAnalysis(
        audio.duration_s,
        tuple(float(b) for b in beats),
        tuple(float(b) for b in beats[bars.downbeats]),
        bars.beats_per_bar,
        spans,
        meter_detected=beats_per_bar is None,
        meter_confidence=bars.confidence,
        subdivision=bars.subdivision,
        grouping=bars.grouping,
        warnings=_warnings(features, beats, spans, bars.subdivision),
    )


def _neural_analysis(
    audio: Audio, features: Features, beats_per_bar: int | None, level: str, offset_beats: float
) -> BeatAnalysis:
    """The beats and downbeats Beat This! finds; its bars kept unless a meter is given (or the
    grid moved), the tempo, confidence and warnings as for the default tracker."""
    from choreo.music.neural import neural_beats

    beats, downbeats = neural_beats(audio)
    beats = _regrid(features, beats, level, offset_beats)
    if len(beats) == 0:
        return _no_beats(audio, beats_per_bar)
    if beats_per_bar is None and not level and not offset_beats and len(downbeats) >= 2:
        index = np.searchsorted(beats, downbeats - 1e-6)
        per_bar = int(np.median(np.diff(index)))
        confidence = float(np.mean(np.diff(index) == per_bar))
    else:
        bars = find_bars(features, beats, beats_per_bar)
        downbeats, per_bar, confidence = beats[bars.downbeats], bars.beats_per_bar, bars.confidence
    spans = _tempo_spans(beats, features)
    return BeatAnalysis(
        audio.duration_s,
        tuple(float(b) for b in beats),
        tuple(float(b) for b in downbeats),
        per_bar,
        spans,
        meter_detected=beats_per_bar is None,
        meter_confidence=confidence,
        warnings=_warnings(features, beats, spans, 2),
    )


def check_grid(level: object, offset_beats: object) -> None:
    """Refuse an alternative grid that is none: ``level`` "", "half" or "double", and an
    ``offset_beats`` within OFFSET_BEATS."""
    check_choice("level", level, ("", *LEVELS))
    check_number("offset_beats", offset_beats, OFFSET_BEATS)


def _check_samples(y: np.ndarray, rate_hz: int) -> None:
    """Refuse samples that are not numbers (a float WAV can hold NaN or infinity)."""
    bad = np.flatnonzero(~np.isfinite(y))
    if len(bad):
        raise ChoreoError(
            f"the song holds {len(bad)} samples that are not numbers (NaN or infinite), the "
            f"first at {bad[0] / rate_hz:.3f} s: repair or re-export it"
        )


def _no_beats(audio: Audio, beats_per_bar: int | None) -> BeatAnalysis:
    """Silence (or too short a song): no beats, and no meter unless one was given."""
    return BeatAnalysis(
        audio.duration_s,
        (),
        (),
        beats_per_bar or 4,
        (),
        meter_detected=beats_per_bar is None,
        meter_confidence=0.0 if beats_per_bar is None else 1.0,
    )


# --- beats -------------------------------------------------------------------------------------
def _track(librosa, features: Features, scale: float = 1.0) -> np.ndarray:
    """The beats, at ``scale`` times the tempo the song's tempogram says (at its dominant level)."""
    envelope = normalised(features.onset) + normalised(features.low)
    tempo = local_tempo(librosa, envelope, features.rate_hz)
    bpm = scale * (tempo.median_bpm if tempo.steady else tempo.bpm)
    frames = track_beats(librosa, envelope, bpm, features.coarse_fps)
    tracked = np.asarray(frames, dtype=float) / features.coarse_fps
    return _onto_the_backbeat(features, _placed(tracked, features))


def _placed(beats: np.ndarray, features: Features) -> np.ndarray:
    """The beats snapped onto onsets, extended to either end, less those in silence."""
    return _drop_silent(_extend(_snap(beats, features.fine, features.fine_fps), features), features)


def _onto_the_backbeat(features: Features, beats: np.ndarray) -> np.ndarray:
    """The beats moved half a beat where the snare's backbeat falls between them. A backbeat is
    a snare on every other beat: a grid whose every other midpoint carries the snare more
    strongly than either half of its beats is on the off-beats (funk's syncopated kick and bass,
    counted twice by the tracker, pull it there)."""
    if len(beats) < MIN_BEATS:
        return beats
    middles = (beats[:-1] + beats[1:]) / 2

    def backbeat(times: np.ndarray) -> float:
        snare = around(features.snare, times, features.coarse_fps, SNAP_S)
        return max(float(snare[0::2].mean()), float(snare[1::2].mean()))

    if backbeat(middles) < BACKBEAT_BETWEEN * backbeat(beats):
        return beats
    return _placed(middles, features)


def _drop_silent(beats: np.ndarray, features: Features) -> np.ndarray:
    """The beats less those the tracker carried on through a silence (nothing sounds there)."""
    if len(beats) == 0:
        return beats
    loudness = around(features.rms, beats, features.coarse_fps, SNAP_S)
    return beats[loudness > SILENT * np.median(loudness)]


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


def _extend(beats: np.ndarray, features: Features) -> np.ndarray:
    """Beats the tracker left out at either end: one period further, while an onset is there
    (at least half a period further, so the search always moves on)."""
    envelope, frame_rate = features.fine, features.fine_fps
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


def _regrid(features: Features, beats: np.ndarray, level: str, offset_beats: float) -> np.ndarray:
    """The alternative grid: every other or third beat (half, third: those the first downbeat is
    among), two or three beats in each (double, triple), moved by ``offset_beats`` beats
    (fractions fall between)."""
    if len(beats) < 2:
        return beats
    if level in ("double", "triple"):
        k = 2 if level == "double" else 3
        beats = np.interp(np.arange(k * len(beats) - k + 1) / k, np.arange(len(beats)), beats)
    elif level in ("half", "third"):
        k = 2 if level == "half" else 3
        downbeats = find_bars(features, beats).downbeats
        beats = beats[(downbeats[0] if len(downbeats) else 0) % k :: k]
    if offset_beats:
        index = np.arange(len(beats)) + offset_beats
        inside = (index >= 0) & (index <= len(beats) - 1)
        beats = np.interp(index[inside], np.arange(len(beats)), beats)
    return beats


# --- tempo, confidence, warnings ---------------------------------------------------------------
def _tempo_spans(beats: np.ndarray, features: Features) -> tuple[TempoSpan, ...]:
    """Split the beats at gaps (silence) and where the interval changes for good; a line
    through each stretch."""
    if len(beats) < 2:
        return ()
    intervals = np.diff(beats)
    gaps = np.flatnonzero(intervals > GAP * np.median(intervals)) + 1
    parts = [part for part in np.split(beats, gaps) if len(part) >= 2]
    return tuple(span for part in parts for span in _steady_spans(part, features, len(parts) > 1))


def _steady_spans(beats: np.ndarray, features: Features, among_others: bool) -> list[TempoSpan]:
    """Split the beats where the interval changes for good; a line through each stretch."""
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
        if len(stretch) < 3 and (len(starts) > 1 or among_others):
            continue  # one interval between two tempi: the change itself
        slope = float(np.polyfit(np.arange(len(stretch)), stretch, 1)[0])
        confidence = _pulse_clarity(features, stretch[0], stretch[-1], slope)
        spans.append(TempoSpan(float(stretch[0]), float(stretch[-1]), 60.0 / slope, confidence))
    return spans


def _pulse_clarity(features: Features, start_s: float, end_s: float, period_s: float) -> float:
    """The onset envelope's autocorrelation at the beat period (best within 5 %), slow swells
    taken out first: a pulse that repeats scores near 1, noise and drones near 0."""
    fps = features.coarse_fps
    envelope = features.onset[int(start_s * fps) : int(end_s * fps) + 1]
    lag = period_s * fps
    if len(envelope) < 3 * lag or lag < 1:
        return 0.0
    window = max(int(fps), 1)
    swells = np.convolve(envelope, np.ones(window) / window, mode="same")
    x = envelope - swells
    energy = float(np.dot(x, x))
    if energy <= 0:
        return 0.0
    lags = range(max(int(lag * 0.95), 1), int(np.ceil(lag * 1.05)) + 1)
    best = max(float(np.dot(x[:-k], x[k:])) for k in lags if k < len(x))
    return float(np.clip(best / energy, 0.0, 1.0))


def _odd_bars_of_two_beats(
    features: Features, beats: np.ndarray, per_bar: int, given: object
) -> bool:
    """Whether bars of 5 or 7 beats with onsets as strong between the beats are really 5 or 7
    beats twice as fast (the tracker's prior pulls toward 120 BPM: a 7/8 at 180 is tracked at
    90, every two eighths, which cannot fit 7)."""
    if given or per_bar not in (5, 7) or len(beats) < 8:
        return False
    bpm = 60 / float(np.median(np.diff(beats)))
    return 2 * bpm <= ODD_METER_BPM and _between_ratio(features, beats) >= OFFBEAT_RATIO


def _between_ratio(features: Features, beats: np.ndarray) -> float:
    """The onsets half way between the beats against those on them."""
    envelope = normalised(features.onset) + normalised(features.low)
    fps = features.coarse_fps

    def strength(times: np.ndarray) -> float:
        frames = np.clip(np.round(times * fps).astype(int), 0, len(envelope) - 1)
        return float(np.mean([envelope[max(f - 1, 0) : f + 2].max() for f in frames]))

    on = strength(beats)
    return strength((beats[:-1] + beats[1:]) / 2) / on if on > 0 else float("inf")


def _snare_on_every_beat(features: Features, beats: np.ndarray) -> bool:
    """A backbeat tracked as the beat: the snare alike on every beat (in a backbeat it is on
    every other one) and the kicks between the beats rather than on them."""
    fps = features.coarse_fps
    snare = around(features.snare, beats, fps, SNAP_S)
    even, odd = snare[0::2].mean(), snare[1::2].mean()
    alike = abs(even - odd) <= BACKBEAT * max(even, odd)
    middles = (beats[:-1] + beats[1:]) / 2
    snare_on = snare.mean() > around(features.snare, middles, fps, SNAP_S).mean()
    kick_on, kick_between = (around(features.low, t, fps, SNAP_S).mean() for t in (beats, middles))
    return bool(alike and snare_on and kick_between > kick_on)


def _warnings(
    features: Features, beats: np.ndarray, spans: tuple[TempoSpan, ...], subdivision: int
) -> tuple[str, ...]:
    """Per steady stretch: where the grid may sit on the off-beats, at half or twice the tempo
    a dancer counts; and a compound meter's eighths."""
    warnings = []
    for span in spans:
        inside = beats[(beats >= span.start_s - 1e-6) & (beats <= span.end_s + 1e-6)]
        if len(inside) < 8:
            continue
        where = f"from {span.start_s:.1f} s to {span.end_s:.1f} s: " if len(spans) > 1 else ""
        warning = _stretch_warning(features, inside, span.bpm)
        if warning:
            warnings.append(where + warning)
    if subdivision == 3:
        warnings.append(
            "each beat is three eighths (a compound meter, counted in its long beats): for the "
            "eighths try {level} triple"
        )
    return tuple(Worded(warning, GRID_OPTIONS) for warning in warnings)


def _stretch_warning(features: Features, beats: np.ndarray, bpm: float) -> str | None:
    ratio = _between_ratio(features, beats)
    if _snare_on_every_beat(features, beats):
        return (
            f"a snare on every beat at {bpm:.1f} BPM: that is likely the backbeat, the beat "
            "twice as fast (try {level} double)"
        )
    if ratio >= OFFBEAT_RATIO:
        how_strong = f"{ratio:.2f} times as strong as" if np.isfinite(ratio) else "there, not"
        return (
            f"the onsets between the beats are {how_strong} on them: the beats may sit on the "
            "off-beat (try {offset_beats} 0.5) or the tempo be twice "
            f"{bpm:.1f} (try {{level}} double)"
        )
    if bpm > FAST_BPM:
        return f"{bpm:.1f} BPM is fast: the beat may be half that (try {{level}} half)"
    if bpm < SLOW_BPM:
        return f"{bpm:.1f} BPM is slow: the beat may be twice that (try {{level}} double)"
    return None
