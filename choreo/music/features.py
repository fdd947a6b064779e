"""The envelopes a song's beats and bars are found from, computed a block at a time (librosa,
imported by the caller): onsets in all bands, in the kick-and-bass band and in the snare band,
a fine onset envelope to snap beats onto, the loudness, and the chroma of the bass band (the
notes the harmony stands on: a bar's chord shows there, not in the melody or the comping).

Features are computed on ``CHUNK_S`` blocks, so memory stays near the decoded samples' own size.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

COARSE_HOP = 512  # ~23 ms frames at 22050 Hz: what the tracker is tuned for
FINE_HOP = 64  # ~3 ms frames: where beats are snapped to
CHUNK_S = 10.0  # features are computed this much at a time
LOW_HZ = 200.0  # the kick and bass band
SNARE_HZ = (1000.0, 5000.0)  # where a snare's rattle stands out from kick and bass
BASS_HZ = (30.0, 300.0)  # the bass notes whose chroma says the harmony
BASS_DECIMATE = 16  # the bass band is analysed at 1/16 of the rate (1378 Hz from 22050)
BASS_FFT = 1024  # 0.74 s at 1378 Hz: 1.3 Hz apart, a semitone at 30 Hz is 1.8 Hz


@dataclass(frozen=True)
class Features:
    onset: np.ndarray  # coarse onset envelope, all bands
    low: np.ndarray  # coarse onset envelope below LOW_HZ
    snare: np.ndarray  # coarse onset envelope in SNARE_HZ
    bass_chroma: np.ndarray  # (12, coarse frames): pitch classes of the bass band
    chroma: np.ndarray  # (12, coarse frames): pitch classes of the whole song, 93 ms windows
    fine: np.ndarray  # fine onset envelope, for snapping
    rms: np.ndarray  # coarse loudness
    rate_hz: int

    @property
    def coarse_fps(self) -> float:
        return self.rate_hz / COARSE_HOP

    @property
    def fine_fps(self) -> float:
        return self.rate_hz / FINE_HOP


def song_features(librosa, y: np.ndarray, sr: int) -> Features:
    """Every envelope of the song, computed ``CHUNK_S`` at a time (with margins, so the blocks
    join seamlessly): a whole-song spectrogram would need many times the samples' memory."""
    margin = 16  # coarse frames each side of a block
    block = max(int(CHUNK_S * sr / COARSE_HOP), 1)
    frames = len(y) // COARSE_HOP + 1
    parts: list[tuple[np.ndarray, ...]] = []
    for first in range(0, frames, block):
        begin = max(first - margin, 0)
        end = min(first + block + margin, frames)
        chunk = y[begin * COARSE_HOP : end * COARSE_HOP]
        keep = slice(first - begin, first - begin + min(block, frames - first))
        parts.append(_chunk_features(librosa, chunk, sr, keep))
    onset, low, snare, bass_chroma, chroma, fine, rms = (
        np.concatenate(p, axis=-1) for p in zip(*parts)
    )
    return Features(onset, low, snare, bass_chroma, chroma, fine, rms, sr)


def _chunk_features(librosa, y: np.ndarray, sr: int, keep: slice) -> tuple[np.ndarray, ...]:
    spectrum = np.abs(librosa.stft(y, n_fft=2048, hop_length=COARSE_HOP))
    mel_db = librosa.power_to_db(librosa.feature.melspectrogram(S=spectrum**2, sr=sr))
    mel_hz = librosa.mel_frequencies(n_mels=mel_db.shape[0], fmax=sr / 2)
    onset = librosa.onset.onset_strength(S=mel_db, sr=sr)
    low = librosa.onset.onset_strength(S=mel_db[mel_hz < LOW_HZ], sr=sr)
    snare_rows = (mel_hz >= SNARE_HZ[0]) & (mel_hz <= SNARE_HZ[1])
    snare = librosa.onset.onset_strength(S=mel_db[snare_rows], sr=sr)
    rms = librosa.feature.rms(S=spectrum)[0]
    chroma = librosa.feature.chroma_stft(S=spectrum**2, sr=sr, tuning=0.0)
    del spectrum, mel_db
    # A click right at the start has no frame before it to rise from: pad so it has one.
    pad = FINE_HOP * 4
    fine = librosa.onset.onset_strength(
        y=np.concatenate([np.zeros(pad, np.float32), y]), sr=sr, hop_length=FINE_HOP, n_fft=512
    )[4:]
    ratio = COARSE_HOP // FINE_HOP
    fine_keep = slice(keep.start * ratio, keep.stop * ratio)
    n = keep.stop - keep.start
    return (
        _fit(onset[keep], n),
        _fit(low[keep], n),
        _fit(snare[keep], n),
        _fit(_bass_chroma(librosa, y, sr)[:, keep], n),
        _fit(chroma[:, keep], n),
        _fit(fine[fine_keep], n * ratio),
        _fit(rms[keep], n),
    )


def _bass_chroma(librosa, y: np.ndarray, sr: int) -> np.ndarray:
    """(12, coarse frames): the energy of each pitch class between BASS_HZ, from the samples
    low-passed and decimated (a low note needs a long window to be told from its neighbours)."""
    import scipy.signal

    rate = sr / BASS_DECIMATE
    low = scipy.signal.resample_poly(y, 1, BASS_DECIMATE).astype(np.float32)
    with warnings.catch_warnings():  # a song's last block may be shorter than one window
        warnings.filterwarnings("ignore", "n_fft=.* is too large", UserWarning)
        frames = librosa.stft(low, n_fft=BASS_FFT, hop_length=COARSE_HOP // BASS_DECIMATE)
    power = np.abs(frames) ** 2
    freqs = np.arange(power.shape[0]) * rate / BASS_FFT
    power[(freqs < BASS_HZ[0]) | (freqs > BASS_HZ[1])] = 0.0
    bins = librosa.filters.chroma(sr=rate, n_fft=BASS_FFT, tuning=0.0, octwidth=None, norm=None)
    return bins @ power


def _fit(values: np.ndarray, n: int) -> np.ndarray:
    """Exactly ``n`` frames (the last block may come out a frame short)."""
    if values.shape[-1] >= n:
        return values[..., :n]
    pad = [(0, 0)] * (values.ndim - 1) + [(0, n - values.shape[-1])]
    return np.pad(values, pad)


def normalised(values: np.ndarray) -> np.ndarray:
    """``values`` over their standard deviation (zeros where they don't vary)."""
    spread = np.std(values)
    return values / spread if spread > 0 else np.zeros_like(values)


def standardised(values: np.ndarray) -> np.ndarray:
    """``values`` less their mean, over their standard deviation (zeros where they don't vary)."""
    spread = np.std(values)
    if spread <= 1e-6 * (abs(values.mean()) + 1e-9):
        return np.zeros_like(values)
    return (values - values.mean()) / spread


def around(envelope: np.ndarray, times_s: np.ndarray, fps: float, reach_s: float) -> np.ndarray:
    """Per time: the envelope's peak within ``reach_s`` of it."""
    frames = np.clip(np.round(times_s * fps).astype(int), 0, len(envelope) - 1)
    reach = max(int(round(reach_s * fps)), 1)
    return np.array([envelope[max(f - reach, 0) : f + reach + 1].max() for f in frames])
