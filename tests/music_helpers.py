"""Songs made in the tests: click tracks at known times (golden beat times by construction)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from choreo.music.decode import Audio, encode

RATE_HZ = 22050


def click_track(times_s, duration_s: float, rate_hz: int = RATE_HZ, accent_every: int = 4) -> Audio:
    """A 20 ms decaying beep at each time; every ``accent_every``-th one (from the first) higher
    and louder, like a metronome's bar."""
    samples = np.zeros(int(duration_s * rate_hz), np.float32)
    n = int(0.02 * rate_hz)
    t = np.arange(n) / rate_hz
    for k, at in enumerate(times_s):
        accent = k % accent_every == 0
        beep = (
            (0.9 if accent else 0.5)
            * np.exp(-t / 0.003)
            * np.sin(2 * np.pi * t * (1760 if accent else 880))
        )
        i = int(round(at * rate_hz))
        samples[i : i + n] += beep[: len(samples) - i]
    return Audio(samples, rate_hz)


def steady_times(bpm: float, first_s: float, until_s: float) -> np.ndarray:
    return np.arange(first_s, until_s, 60.0 / bpm)


def write_clicks(path: Path, times_s, duration_s: float) -> Path:
    return encode(click_track(times_s, duration_s), path)


def first_click_s(samples: np.ndarray, rate_hz: int, threshold: float = 0.2) -> float:
    """When the signal first exceeds ``threshold`` (of full scale)."""
    loud = np.flatnonzero(np.abs(samples) > threshold)
    return float(loud[0] / rate_hz) if len(loud) else float("nan")
