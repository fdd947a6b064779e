"""Beat tracking against exact truth: songs synthesised here (numpy), so every beat and downbeat
time is known by construction.

Per song: the tempo error (detected tempo of the longest steady stretch against the song's own
at that point), beat F-measure and downbeat F-measure (a detection within +-70 ms of a true one,
each used once), the meter found (the detector is NOT told it), the confidence, and the time the
analysis took; beside plain librosa (``beat_track`` on its default onset envelope) in the same
run. librosa gives no downbeats: its column is blank.

Goals: every steady 4/4 and 3/4 song beat F >= 0.95 and downbeat F >= 0.9; the tempo change
beat F >= 0.9; the ambient piece said to have no steady beat.

Run: python benchmarks/bench_beats.py [--only NAME]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from choreo.music.beats import detect_beats, require_librosa  # noqa: E402
from choreo.music.decode import Audio  # noqa: E402

RATE_HZ = 22050
TOLERANCE_S = 0.07
ROOTS_HZ = (65.41, 49.0, 55.0, 43.65)  # C G A F: one chord a bar, round and round
TRIADS = ((1, 1.26, 1.5), (1, 1.26, 1.5), (1, 1.19, 1.5), (1, 1.26, 1.5))  # major, minor


@dataclass
class Song:
    name: str
    goal: str  # "steady" (beat F >= 0.95, downbeat F >= 0.9), "change" (beat F >= 0.9),
    # "none" (said to have no steady beat) or "" (no goal: a hard case, shown as it is)
    beats_s: np.ndarray
    downbeats_s: np.ndarray
    samples: np.ndarray
    tempo_bpm: float  # the true tempo of the longest steady stretch (0: no beat)
    notes: list[str] = field(default_factory=list)


# --- instruments -------------------------------------------------------------------------------
def _t(duration_s: float) -> np.ndarray:
    return np.arange(int(duration_s * RATE_HZ)) / RATE_HZ


def kick() -> np.ndarray:
    t = _t(0.3)
    sweep = 45 + 110 * np.exp(-t / 0.03)
    return np.sin(2 * np.pi * np.cumsum(sweep) / RATE_HZ) * np.exp(-t / 0.12)


def snare(rng) -> np.ndarray:
    t = _t(0.2)
    noise = np.diff(rng.standard_normal(len(t) + 1)) * 0.5
    return (noise * np.exp(-t / 0.06) + 0.6 * np.sin(2 * np.pi * 190 * t) * np.exp(-t / 0.04)) * 0.8


def hat(rng, length_s: float = 0.04) -> np.ndarray:
    t = _t(length_s)
    return np.diff(rng.standard_normal(len(t) + 2), 2) * 0.25 * np.exp(-t / 0.01)


def tone(freqs_hz, duration_s: float, attack_s: float = 0.01, decay_s: float = 0.4) -> np.ndarray:
    t = _t(duration_s)
    wave = sum(np.sin(2 * np.pi * f * t) for f in freqs_hz) / len(freqs_hz)
    envelope = np.minimum(t / attack_s, 1) * np.exp(-t / decay_s)
    fade = np.minimum((duration_s - t) / 0.02, 1)  # no click at the cut
    return wave * envelope * fade


def chord(bar: int, octave: float = 4.0) -> list[float]:
    root = ROOTS_HZ[bar % 4] * octave
    return [root * r for r in TRIADS[bar % 4]]


def add(track: np.ndarray, at_s: float, sound: np.ndarray, gain: float) -> None:
    i = int(round(at_s * RATE_HZ))
    if i >= len(track):
        return
    n = min(len(sound), len(track) - i)
    track[i : i + n] += gain * sound[:n]


# --- songs -------------------------------------------------------------------------------------
def beat_times(tempo_at, first_s: float, until_s: float) -> np.ndarray:
    """Beats from ``first_s`` while before ``until_s``; ``tempo_at(t)`` the BPM at time t."""
    times = [first_s]
    while times[-1] + 60 / tempo_at(times[-1]) < until_s:
        times.append(times[-1] + 60 / tempo_at(times[-1]))
    return np.asarray(times)


def band(
    name: str,
    beats: np.ndarray,
    per_bar: int = 4,
    pickup: int = 0,
    kick_on=(0, 2),
    snare_on=(1, 3),
    kick_gain=0.8,
    snare_gain=0.5,
    swing: float = 0.5,
    offbeat_stabs: float = 0.0,
    chords_on=None,
    intro_s: float = 0.0,
    seed: int = 0,
    goal: str = "steady",
    tempo_bpm: float | None = None,
) -> Song:
    """A drum kit, a bass note on each bar's first beat and a chord a bar (changing every bar):
    ``beats`` are the true beats, bar 1 starts at beat ``pickup``; ``kick_on`` beats of the bar
    counted from 0 (2.5: half way between the third and fourth)."""
    rng = np.random.default_rng(seed)
    duration_s = beats[-1] + 1.5
    track = np.zeros(int(duration_s * RATE_HZ))
    if intro_s:  # soft pads before the band comes in
        for k, at in enumerate(np.arange(0.0, intro_s, 2.0)):
            add(track, at, tone(chord(k, 2), 2.2, attack_s=0.6, decay_s=3.0), 0.15)
    kick_sound, snare_sound = kick(), snare(rng)
    for i, at in enumerate(beats):
        position = (i - pickup) % per_bar
        bar = (i - pickup) // per_bar
        period = (beats[i + 1] if i + 1 < len(beats) else at + (at - beats[i - 1])) - at
        for kick_at in kick_on:  # beats of the bar; fractions fall between them
            if i >= pickup and int(kick_at) == position:
                add(track, at + (kick_at - position) * period, kick_sound, kick_gain)
        if position in snare_on:
            add(track, at, snare_sound, snare_gain)
        add(track, at, hat(rng), 0.5)
        add(track, at + swing * period, hat(rng), 0.35)
        if offbeat_stabs:
            add(track, at + period / 2, tone(chord(bar, 4), 0.12, decay_s=0.08), offbeat_stabs)
        if i >= pickup and position == 0:
            bar_s = period * per_bar
            add(track, at, tone([ROOTS_HZ[bar % 4]], bar_s, decay_s=0.8), 0.6)  # bass
            for beat in chords_on or [0]:
                add(track, at + beat * period, tone(chord(bar), period * 0.9, decay_s=0.6), 0.25)
    downbeats = beats[pickup::per_bar]
    peak = np.max(np.abs(track))
    if tempo_bpm is None:
        tempo_bpm = float(60 / np.median(np.diff(beats)))
    return Song(name, goal, beats, downbeats, (0.9 * track / peak).astype(np.float32), tempo_bpm)


def ambient(seed: int = 3) -> Song:
    """Pads that swell and fade at irregular times, over soft noise: no beat at all."""
    rng = np.random.default_rng(seed)
    duration_s = 30.0
    track = 0.01 * rng.standard_normal(int(duration_s * RATE_HZ))
    at = 0.0
    while at < duration_s - 1:
        length = rng.uniform(2.5, 6.0)
        add(track, at, tone(chord(int(rng.integers(4)), 2), length, attack_s=1.5, decay_s=4), 0.4)
        at += rng.uniform(1.3, 4.1)
    peak = np.max(np.abs(track))
    empty = np.asarray([])
    return Song("ambient", "none", empty, empty, (0.9 * track / peak).astype(np.float32), 0.0)


def noise(seed: int = 4) -> Song:
    rng = np.random.default_rng(seed)
    samples = (0.3 * rng.standard_normal(int(20 * RATE_HZ))).astype(np.float32)
    empty = np.asarray([])
    return Song("white noise", "none", empty, empty, samples, 0.0)


def songs() -> list[Song]:
    steady = lambda bpm: lambda t: bpm  # noqa: E731
    change = lambda t: 100.0 if t < 24 else 130.0  # noqa: E731
    ramp = lambda t: 96 + 36 * min(max((t - 2) / 40, 0), 1)  # noqa: E731
    return [
        band("rock 90", beat_times(steady(90), 0.4, 30)),
        band("rock 120", beat_times(steady(120), 0.25, 30)),
        band("house 128", beat_times(steady(128), 0.3, 30), kick_on=(0, 1, 2, 3), swing=0.5),
        band(
            "backbeat, loud snare", beat_times(steady(104), 0.3, 30), kick_gain=0.35, snare_gain=1.0
        ),
        band("swing 120", beat_times(steady(120), 0.3, 30), swing=2 / 3),
        band(
            "off-beat stabs 96", beat_times(steady(96), 0.3, 30), offbeat_stabs=0.6, kick_gain=0.5
        ),
        band("quiet intro 110", beat_times(steady(110), 8.0, 36), intro_s=8.0),
        band("pickup 116", beat_times(steady(116), 0.3, 30), pickup=2),
        band(
            "waltz 3/4 138",
            beat_times(steady(138), 0.3, 30),
            per_bar=3,
            kick_on=(0,),
            snare_on=(1, 2),
            snare_gain=0.3,
            chords_on=(1, 2),
        ),
        band("change 100->130", beat_times(change, 0.3, 50), goal="change", tempo_bpm=130.0),
        band("accelerando 96->132", beat_times(ramp, 0.3, 44), goal="", tempo_bpm=float("nan")),
        band(
            "one-drop 76",
            beat_times(steady(76), 0.3, 30),
            kick_on=(2,),
            snare_on=(2,),
            offbeat_stabs=0.8,
            goal="",
        ),
        band(
            "drum'n'bass 174",
            beat_times(steady(174), 0.3, 30),
            kick_on=(0, 2.5),
            snare_on=(1, 3),
            snare_gain=0.9,
            goal="",
        ),
        ambient(),
        noise(),
    ]


# --- scoring -----------------------------------------------------------------------------------
def f_measure(detected, truth) -> float:
    detected, truth = list(np.sort(detected)), np.sort(truth)
    if len(truth) == 0 or len(detected) == 0:
        return float(len(truth) == len(detected))
    hits = 0
    for true in truth:
        near = [d for d in detected if abs(d - true) <= TOLERANCE_S]
        if near:
            detected.remove(min(near, key=lambda d: abs(d - true)))
            hits += 1
    precision, recall = hits / (hits + len(detected)), hits / len(truth)
    return 0.0 if hits == 0 else 2 * precision * recall / (precision + recall)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="run only the songs whose name contains this")
    args = parser.parse_args()
    librosa = require_librosa()
    warm_up = songs()[0].samples[: 5 * RATE_HZ]  # numba compiles on first use: not timed
    detect_beats(Audio(warm_up, RATE_HZ))
    librosa.beat.beat_track(y=warm_up, sr=RATE_HZ)
    header = (
        f"{'song':22} {'tempo err':>9} {'beat F':>6} {'down F':>6} {'meter':>9} {'conf':>5} "
        f"{'time':>6} {'goal':>6} | {'librosa tempo err':>17} {'beat F':>6} {'time':>6}"
    )
    print(header)
    print("-" * len(header))
    for song in songs():
        if args.only and args.only not in song.name:
            continue
        began = time.perf_counter()
        analysis = detect_beats(Audio(song.samples, RATE_HZ), beats_per_bar=None)
        took = time.perf_counter() - began
        began = time.perf_counter()
        tempo, plain = librosa.beat.beat_track(y=song.samples, sr=RATE_HZ, units="time")
        plain_took = time.perf_counter() - began
        plain_bpm = float(np.atleast_1d(tempo)[0])
        if not song.tempo_bpm:  # no beat: what matters is whether it says so
            verdict = "steady beat" if analysis.steady else "no steady beat"
            goal = "MISSED" if analysis.steady else "met"
            print(
                f"{song.name:22} {verdict:>32} {analysis.confidence:5.2f} {took:5.2f}s {goal:>6} | "
                f"{plain_bpm:7.1f} BPM, {len(plain)} beats {plain_took:5.2f}s"
            )
            continue
        error = _tempo_error(analysis.bpm, song.tempo_bpm)
        plain_error = _tempo_error(plain_bpm, song.tempo_bpm)
        meter = f"{analysis.beats_per_bar} ({analysis.meter_confidence:.2f})"
        beat_f = f_measure(analysis.beats_s, song.beats_s)
        down_f = f_measure(analysis.downbeats_s, song.downbeats_s)
        met = {"steady": beat_f >= 0.95 and down_f >= 0.9, "change": beat_f >= 0.9}.get(song.goal)
        goal = "-" if met is None else "met" if met else "MISSED"
        print(
            f"{song.name:22} {error:>9} {beat_f:6.2f} {down_f:6.2f} {meter:>9} "
            f"{analysis.confidence:5.2f} {took:5.2f}s {goal:>6} | {plain_error:>17} "
            f"{f_measure(plain, song.beats_s):6.2f} {plain_took:5.2f}s"
        )
        for warning in analysis.warnings:
            print(f"{'':22} warning: {warning}")
            for level in ("half", "double"):  # what following the warning gives
                if f"--level {level}" in warning:
                    other = detect_beats(Audio(song.samples, RATE_HZ), None, level)
                    print(
                        f"{'':22} with --level {level}: {other.bpm:.1f} BPM, beat F "
                        f"{f_measure(other.beats_s, song.beats_s):.2f}, downbeat F "
                        f"{f_measure(other.downbeats_s, song.downbeats_s):.2f}"
                    )
    return 0


def _tempo_error(bpm: float, truth: float) -> str:
    return "-" if np.isnan(truth) else f"{100 * (bpm - truth) / truth:+.1f}%"


if __name__ == "__main__":
    sys.exit(main())
