"""The tempo along a song, at one level: what the beat tracker is told to follow.

librosa's tempogram (the onset envelope's autocorrelation over 8 s windows) gives a tempo per
frame, but the strongest period of a window is not always the level the song is counted at: a
ballad at 60 with piano in eighths reads 120 in places, funk at 100 with sixteenth hats reads 133
(4/3), drum'n'bass at 174 reads 116 (2/3). The whole song's tempogram, averaged, settles on one
level (librosa's global tempo: the dominant level). Each frame whose tempo is that level times 2,
4/3 or 3/2 (or their inverses) is **folded** onto it, but only where its own autocorrelation
repeats at the dominant period nearly as strongly as at its own (``FOLD_STRENGTH``): there the
music still carries the dominant level, and the tracker only preferred another. A real change of
tempo (100 to 130 is close to 4/3) has no such repetition at the old period, and is kept.

The tempogram is computed a block at a time (a whole song's, 384 lags a frame, would take
several times the samples' memory) and kept in float32 to fold it once the dominant is known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.music.features import COARSE_HOP

WINDOW = 384  # tempogram frames (~8.9 s at 22050 Hz): librosa's default
# frames of tempogram computed at a time: librosa's autocorrelation holds a block's frames (and
# margins) several times over in float64 and complex128, the peak of a 2-minute song's detection
# (1024: 3.95x the samples, 512: 2.9x, for 30 % more of the tempogram's CPU, 0.07 s there)
BLOCK = 512
START_BPM = 120.0  # librosa's prior: a log-normal around 120 BPM, one octave wide...
MAX_BPM = 320.0  # ...and nothing faster than this
FOLDS = (2.0, 0.5, 4 / 3, 3 / 4, 3 / 2, 2 / 3)  # the levels a frame may stray to from the dominant
FOLD_REACH = 0.06  # a frame this near the dominant times a fold is at that level (lags are coarse)
# a frame is folded where its autocorrelation at the dominant period is at least this much of its
# own: folded frames score 0.87 to 1.6, real tempo changes 0.01 to 0.03 (benchmarks/bench_beats)
FOLD_STRENGTH = 0.7
SMOOTH_S = 6.0  # the local tempo's median filter
STEADY_SPREAD = 0.03  # local tempo within this of its median nearly everywhere: one tempo


@dataclass(frozen=True)
class LocalTempo:
    bpm: np.ndarray  # per coarse frame, at the dominant level and smoothed
    dominant_bpm: float  # the whole song's tempo (librosa's global estimate)

    @property
    def median_bpm(self) -> float:
        return float(np.median(self.bpm))

    @property
    def steady(self) -> bool:
        """One tempo: within STEADY_SPREAD of the median on 90 % of the song."""
        return bool(np.mean(np.abs(self.bpm / self.median_bpm - 1) <= STEADY_SPREAD) >= 0.9)


def local_tempo(librosa, envelope: np.ndarray, rate_hz: int) -> LocalTempo:
    """The tempo per frame of the onset ``envelope`` (coarse frames), folded onto the song's
    dominant level and median-filtered over SMOOTH_S."""
    import scipy.ndimage

    tempogram = _tempogram(librosa, envelope, rate_hz)
    bpms = librosa.tempo_frequencies(WINDOW, hop_length=COARSE_HOP, sr=rate_hz)
    weight = _log_prior(bpms)
    own = np.concatenate(  # a block at a time: the weighted tempogram is float64
        [
            np.argmax(np.log1p(1e6 * tempogram[:, first : first + BLOCK]) + weight[:, None], axis=0)
            for first in range(0, tempogram.shape[1], BLOCK)
        ]
    )
    dominant = int(np.argmax(np.log1p(1e6 * tempogram.mean(axis=1)) + weight))
    folded = fold(tempogram, bpms, own, float(bpms[dominant]))
    fps = rate_hz / COARSE_HOP
    width = int(SMOOTH_S * fps) // 2 * 2 + 1
    smooth = scipy.ndimage.median_filter(folded, size=width, mode="nearest")
    return LocalTempo(smooth, float(bpms[dominant]))


def fold(tempogram: np.ndarray, bpms: np.ndarray, own: np.ndarray, dominant_bpm: float):
    """Per frame, the tempo: ``bpms[own]`` (each frame's strongest lag), or the strongest lag
    within FOLD_REACH of ``dominant_bpm`` where the frame's tempo is the dominant's times one of
    FOLDS and the ``tempogram`` (lags x frames) repeats there at least FOLD_STRENGTH as strongly."""
    tempo = bpms[own].astype(float)
    ratio = tempo / dominant_bpm
    related = np.any([np.abs(ratio / k - 1) <= FOLD_REACH for k in FOLDS], axis=0)
    near = np.flatnonzero(np.abs(bpms / dominant_bpm - 1) <= FOLD_REACH)
    if len(near) == 0:
        return tempo
    frames = np.arange(tempogram.shape[1])
    best = near[np.argmax(tempogram[near], axis=0)]
    strong = tempogram[best, frames] >= FOLD_STRENGTH * tempogram[own, frames]
    return np.where(related & strong, bpms[best], tempo)


def _tempogram(librosa, envelope: np.ndarray, rate_hz: int) -> np.ndarray:
    """(WINDOW lags, frames): librosa's tempogram a block at a time, with margins so the blocks
    join seamlessly."""
    margin = WINDOW // 2 + 64
    tempogram = np.empty((WINDOW, len(envelope)), dtype=np.float32)
    for first in range(0, len(envelope), BLOCK):
        low = max(first - margin, 0)
        part = envelope[low : first + BLOCK + margin]
        block = librosa.feature.tempogram(
            onset_envelope=part, sr=rate_hz, hop_length=COARSE_HOP, win_length=WINDOW
        )
        kept = block[:, first - low : first - low + BLOCK]
        tempogram[:, first : first + kept.shape[1]] = kept
    return tempogram


def _log_prior(bpms: np.ndarray) -> np.ndarray:
    """librosa's prior on the tempo, as its ``tempo`` weighs the tempogram with it."""
    with np.errstate(divide="ignore"):
        prior = -0.5 * (np.log2(bpms) - np.log2(START_BPM)) ** 2
    prior[bpms >= MAX_BPM] = -np.inf  # bpms[0] is the zero lag: infinitely fast
    return prior
