"""Synthesize ``groove.ogg``, the song the shipped dances dance to: made here with numpy, so the
repository carries no one's recording. Run from the repository root:

    python motions/songs/groove.py

112 BPM in 4/4: half a second of silence, then 9 bars of a kick on every beat (louder on each
bar's first), a hi-hat between the beats, a bass line and a chord stab every other bar. The
dances start at the first kick (``start: 0.5``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

BPM = 112
BARS = 9
BEATS_PER_BAR = 4
LEAD_IN_S = 0.5
RATE_HZ = 22050
BASS_HZ = (55.0, 55.0, 65.41, 49.0)  # A, A, C, G: one per bar, round and round
CHORD_HZ = ((220.0, 261.63, 329.63), (196.0, 246.94, 293.66))


def _tone(freq_hz: float, duration_s: float, decay_s: float, rate_hz: int) -> np.ndarray:
    t = np.arange(int(duration_s * rate_hz)) / rate_hz
    return np.sin(2 * np.pi * freq_hz * t) * np.exp(-t / decay_s)


def _kick(rate_hz: int, loud: float) -> np.ndarray:
    t = np.arange(int(0.25 * rate_hz)) / rate_hz
    sweep = 50 + 150 * np.exp(-t / 0.03)  # a falling pitch: the thump
    thump = np.sin(2 * np.pi * np.cumsum(sweep) / rate_hz) * np.exp(-t / 0.08)
    click = np.random.default_rng(1).standard_normal(len(t)) * np.exp(-t / 0.004)  # the beater
    return loud * (thump + 0.5 * click)


def _hat(rate_hz: int, rng: np.random.Generator) -> np.ndarray:
    n = int(0.05 * rate_hz)
    noise = np.diff(rng.standard_normal(n + 1))  # brighter than white
    return 0.03 * noise * np.exp(-np.arange(n) / (0.012 * rate_hz))


def synthesize(
    bpm: float = BPM, bars: int = BARS, lead_in_s: float = LEAD_IN_S, rate_hz: int = RATE_HZ
) -> np.ndarray:
    """The groove as float32 mono samples in [-1, 1]."""
    beat_s = 60.0 / bpm
    total_s = lead_in_s + bars * BEATS_PER_BAR * beat_s + 1.0
    song = np.zeros(int(total_s * rate_hz))
    rng = np.random.default_rng(13)

    def add(sound: np.ndarray, at_s: float) -> None:
        i = int(round(at_s * rate_hz))
        song[i : i + len(sound)] += sound[: len(song) - i]

    for beat in range(bars * BEATS_PER_BAR):
        at = lead_in_s + beat * beat_s
        bar, in_bar = divmod(beat, BEATS_PER_BAR)
        add(_kick(rate_hz, 0.9 if in_bar == 0 else 0.6), at)
        add(_hat(rate_hz, rng), at + beat_s / 2)
        add(0.25 * _tone(BASS_HZ[bar % 4], beat_s, 0.3, rate_hz), at)
        if in_bar == 0 and bar % 2 == 0:
            chord = CHORD_HZ[(bar // 2) % 2]
            add(sum(0.07 * _tone(f, 2 * beat_s, 0.6, rate_hz) for f in chord), at)
    return (song / max(1.0, np.abs(song).max() * 1.05)).astype(np.float32)


def main() -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # this checkout's choreo
    from choreo.audio import Audio, encode

    path = encode(Audio(synthesize(), RATE_HZ), Path(__file__).with_name("groove.ogg"))
    print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
