"""Songs made in the tests: click tracks at known times (golden beat times by construction)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from choreo.music.decode import Audio, encode

RATE_HZ = 22050


def click_track(
    times_s, duration_s: float, rate_hz: int = RATE_HZ, accent_every: int = 4, first_accent: int = 0
) -> Audio:
    """A 20 ms decaying beep at each time; every ``accent_every``-th one (from the one numbered
    ``first_accent``, from 0) higher and louder, like a metronome's bar."""
    samples = np.zeros(int(duration_s * rate_hz), np.float32)
    n = int(0.02 * rate_hz)
    t = np.arange(n) / rate_hz
    for k, at in enumerate(times_s):
        accent = k >= first_accent and (k - first_accent) % accent_every == 0
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


def band_track(times_s, per_bar: int = 4, pickup: int = 0, snare_gain: float = 0.5) -> Audio:
    """A small band on the beats ``times_s``: a kick on each bar's first beat (and on its third in
    4/4), a snare on the others (``snare_gain``; the kick is 0.4), a hi-hat on every beat and a
    bass note and a chord on each bar's first beat, the chord changing every bar. Bar 1 starts at
    beat ``pickup`` (the beats before it are a pickup: snare and hi-hat only)."""
    rng = np.random.default_rng(0)
    duration_s = float(times_s[-1]) + 1.0
    samples = np.zeros(int(duration_s * RATE_HZ), np.float32)
    t = np.arange(int(0.3 * RATE_HZ)) / RATE_HZ
    kick = np.sin(2 * np.pi * np.cumsum(45 + 110 * np.exp(-t / 0.03)) / RATE_HZ) * np.exp(-t / 0.1)
    snare = np.diff(rng.standard_normal(len(t) + 1)) * np.exp(-t / 0.05)
    hat = np.diff(rng.standard_normal(len(t) + 2), 2) * np.exp(-t / 0.01) * 0.1
    roots_hz = (130.8, 98.0, 110.0, 87.3)  # C G A F

    def add(at_s: float, sound: np.ndarray, gain: float) -> None:
        i = int(round(at_s * RATE_HZ))
        n = min(len(sound), len(samples) - i)
        samples[i : i + n] += gain * sound[:n]

    for k, at in enumerate(times_s):
        position, bar = (k - pickup) % per_bar, (k - pickup) // per_bar
        add(at, hat, 1.0)
        if k >= pickup and position in ((0, 2) if per_bar == 4 else (0,)):
            add(at, kick, 0.4)
        else:
            add(at, snare, snare_gain)
        if k >= pickup and position == 0:
            bar_t = np.arange(int(per_bar * 0.4 * RATE_HZ)) / RATE_HZ
            root = roots_hz[bar % 4]
            chord = sum(np.sin(2 * np.pi * root * r * bar_t) for r in (0.5, 1, 1.26, 1.5))
            add(at, chord * np.exp(-bar_t / 0.8), 0.1)
    return Audio(samples / np.max(np.abs(samples)), RATE_HZ)


def write(folder, name: str, text: str):
    path = folder / name
    path.write_text(textwrap.dedent(text).lstrip())
    return path


BPM_TOLERANCE = 0.5


BEAT_TOLERANCE_S = 0.015


def assert_beats_match(detected, expected) -> None:
    detected, expected = np.asarray(detected), np.asarray(expected)
    assert len(detected) == len(expected), (detected, expected)
    assert np.max(np.abs(detected - expected)) <= BEAT_TOLERANCE_S
