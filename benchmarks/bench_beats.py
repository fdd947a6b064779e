"""Beat tracking against exact truth: songs synthesised here (numpy), so every beat and downbeat
time is known by construction.

Two sets. The earlier one: steady 4/4 and 3/4 bands, a tempo change, ambient pads and noise
(goals: every steady song beat F >= 0.95 and downbeat F >= 0.9; the tempo change beat F >= 0.9;
the ambient piece said to have no steady beat). The set of issue 31: a band with harmonic
instruments (strings struck with their partials, pads, a bass) and a drum kit played with
velocity and up to 10 ms (drums) or 20 ms (notes) of humanised timing, from fixed seeds: swing
with a walking bass and comping off the beat, funk, 6/8, 7/8 as 2+2+3, 5/4, an accelerando,
rubato piano, a breakdown, a drumless intro, fills, drum'n'bass at 174, a 60 BPM ballad, 3 s of
silence and a pickup (goals: beat F >= 0.97 and downbeat F >= 0.9 on average, the meter right on
every song, the tempo within 1 % at the level a dancer counts).

Per song: the tempo error (detected tempo of the longest steady stretch against the song's own),
beat F-measure and downbeat F-measure (a detection within +-70 ms of a true one, each used once),
the meter found as a time signature (the detector is NOT told it), the confidence, and the time
the analysis took; beside plain librosa (``beat_track`` on its default onset envelope) and, when
it is installed with its weights, Beat This! (``pip install beat-this``). librosa gives no
downbeats.

Last, the budget: a 5-minute song (the rock band with fills, 300 s at 120 BPM) analysed in a
fresh process after a warm-up: the time detect_beats takes and the process's peak resident memory
(librosa and numpy included; goals: within 10 s and 400 MB).

Run: python benchmarks/bench_beats.py [--only NAME] [--set issue|earlier|all] [--no-budget]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
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
    meter: str = "4/4"


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
    meter: str = "4/4",
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
    samples = (0.9 * track / peak).astype(np.float32)
    return Song(name, goal, beats, downbeats, samples, tempo_bpm, meter)


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
            meter="3/4",
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


# --- the songs of issue 31: a band with velocity and humanised timing --------------------------
# Each drum hit is moved by up to HUMAN_S (uniform) and played at a random velocity; the notes of
# the harmonic instruments by up to twice that. The truth is the grid the players aim at.
HUMAN_S = 0.01
NOTE_HZ = {
    n: 440 * 2 ** ((i - 9) / 12) for i, n in enumerate("C Db D Eb E F Gb G Ab A Bb B".split())
}
PROGRESSION = (("C", 0, 4, 7), ("A", 0, 3, 7), ("F", 0, 4, 7), ("G", 0, 4, 7, 10))  # I vi IV V7
SECOND = (
    ("D", 0, 3, 7, 10),
    ("G", 0, 4, 7, 10),
    ("C", 0, 4, 7, 11),
    ("A", 0, 4, 7, 10),
)  # ii V I VI


def pitch_hz(root: str, semitones: float, octave: int) -> float:
    return NOTE_HZ[root] * 2 ** (semitones / 12 + octave - 4)


def note(
    freq_hz: float, duration_s: float, bright: float = 0.5, decay_s: float = 0.6
) -> np.ndarray:
    """A plucked or struck string: partials falling off by ``bright``, the high ones dying first."""
    t = _t(duration_s)
    wave = sum(
        bright ** (k - 1) * np.sin(2 * np.pi * k * freq_hz * t) * np.exp(-t * k / (2 * decay_s))
        for k in range(1, 6)
        if k * freq_hz < RATE_HZ / 2
    )
    attack = np.minimum(t / 0.005, 1)
    return wave * attack * np.exp(-t / decay_s) * np.minimum((duration_s - t) / 0.02, 1)


def pad(freqs_hz, duration_s: float) -> np.ndarray:
    t = _t(duration_s)
    wave = sum(np.sin(2 * np.pi * f * t) + 0.3 * np.sin(4 * np.pi * f * t) for f in freqs_hz)
    swell = np.minimum(t / 0.4, 1) * np.minimum((duration_s - t) / 0.3, 1)
    return wave / len(freqs_hz) * swell


def tom(freq_hz: float) -> np.ndarray:
    t = _t(0.3)
    sweep = freq_hz * (1 + 0.5 * np.exp(-t / 0.02))
    return np.sin(2 * np.pi * np.cumsum(sweep) / RATE_HZ) * np.exp(-t / 0.15)


class Band:
    """Instruments played into one track at humanised times and velocities."""

    def __init__(self, duration_s: float, seed: int):
        self.rng = np.random.default_rng(seed)
        self.track = np.zeros(int(duration_s * RATE_HZ))
        self.last_s = 0.0  # the last sound's start: no beat after it is heard
        self.kick, self.snare, self.hats = (
            kick(),
            snare(self.rng),
            [hat(self.rng) for _ in range(4)],
        )
        self.ride = [hat(self.rng, 0.25) for _ in range(4)]

    def play(self, at_s: float, sound: np.ndarray, gain: float, loose: float = 1.0) -> None:
        at_s += self.rng.uniform(-1, 1) * HUMAN_S * loose
        add(self.track, max(at_s, 0.0), sound, gain * self.rng.uniform(0.8, 1.0))
        self.last_s = max(self.last_s, at_s)

    def drum(self, what: str, at_s: float, gain: float) -> None:
        sound = {
            "kick": self.kick,
            "snare": self.snare,
            "hat": self.hats[self.rng.integers(4)],
            "ride": self.ride[self.rng.integers(4)],
            "tom": tom(110 + 40 * self.rng.integers(3)),
        }[what]
        self.play(at_s, sound, gain)

    def chord(self, at_s, chord, duration_s, gain=0.2, octave=4, bright=0.5) -> None:
        root, *intervals = chord
        for semitones in intervals:
            self.play(at_s, note(pitch_hz(root, semitones, octave), duration_s, bright), gain, 2)

    def bass(self, at_s, root, semitones, duration_s, gain=0.5) -> None:
        self.play(at_s, note(pitch_hz(root, semitones, 2), duration_s, 0.3, 0.5), gain, 2)

    def pad(self, at_s, chord, duration_s, gain=0.15) -> None:
        root, *intervals = chord
        add(self.track, at_s, pad([pitch_hz(root, s, 3) for s in intervals], duration_s), gain)
        self.last_s = max(self.last_s, at_s)

    def song(self, name, beats, downbeats, meter, tempo_bpm=None) -> Song:
        """The song, its truth the beats up to the last sound (a song's last partial bar is not
        played: beats in the silence after it are not heard, so not to be found)."""
        heard = self.last_s + TOLERANCE_S
        beats, downbeats = np.asarray(beats), np.asarray(downbeats)
        beats, downbeats = beats[beats <= heard], downbeats[downbeats <= heard]
        peak = np.max(np.abs(self.track))
        samples = (0.9 * self.track / peak).astype(np.float32)
        if tempo_bpm is None:
            tempo_bpm = float(60 / np.median(np.diff(beats)))
        song = Song(name, "issue", np.asarray(beats), np.asarray(downbeats), samples, tempo_bpm)
        song.meter = meter
        return song


def bars_of(beats: np.ndarray, per_bar: int, pickup: int = 0):
    """(bar number, its beats and the next bar's first) for each whole bar from beat ``pickup``."""
    beats = np.append(beats, 2 * beats[-1] - beats[-2])
    for bar, first in enumerate(range(pickup, len(beats) - per_bar, per_bar)):
        yield bar, beats[first : first + per_bar + 1]


def period_after(beats: np.ndarray, i: int) -> float:
    return beats[i + 1] - beats[i] if i + 1 < len(beats) else beats[i] - beats[i - 1]


def rock_bar(band: Band, times, bar: int, chords=PROGRESSION, eighths=True, gain=1.0) -> None:
    """Kick on 1 and 3, snare on 2 and 4, hats on the eighths, bass on 1 and 3, a chord a bar."""
    chord = chords[bar % len(chords)]
    for k, at in enumerate(times[:4]):
        period = times[k + 1] - at
        band.drum("kick" if k % 2 == 0 else "snare", at, (0.8 if k % 2 == 0 else 0.5) * gain)
        band.drum("hat", at, 0.3 * gain)
        if eighths:
            band.drum("hat", at + period / 2, 0.2 * gain)
        if k % 2 == 0:
            band.bass(at, chord[0], 0 if k == 0 else chord[3], 2 * period)
    band.chord(times[0], chord, times[4] - times[0], 0.2)


def rock(name, beats, seed, pickup=0, fills=False) -> Song:
    """A rock band; where the beats stop for a while (silence), the band stops with them."""
    band = Band(beats[-1] + 2, seed)
    gaps = np.flatnonzero(np.diff(beats) > 2 * np.median(np.diff(beats))) + 1
    for k, part in enumerate(np.split(beats, gaps)):
        _rock(band, part, pickup if k == 0 else 0, fills)
    return band.song(name, beats, beats[pickup::4], "4/4")


def _rock(band: Band, beats: np.ndarray, pickup: int, fills: bool) -> None:
    for k in range(pickup):  # the pickup: a snare roll and a chord leading in
        band.drum("snare", beats[k], 0.4)
        band.drum("snare", (beats[k] + beats[k + 1]) / 2, 0.3)
        band.chord(beats[k], PROGRESSION[3], beats[k + 1] - beats[k], 0.12)
    for bar, times in bars_of(beats, 4, pickup):
        if fills and bar % 4 == 3:  # a fill over the last two beats: toms and snare in sixteenths
            rock_bar(band, times, bar)
            for k in (2, 3):
                period = times[k + 1] - times[k]
                for s in range(4):
                    band.drum("tom" if s % 2 else "snare", times[k] + s * period / 4, 0.5)
        else:
            rock_bar(band, times, bar)
        if fills and bar % 4 == 0 and bar:
            band.drum("ride", times[0], 0.6)  # a crash on the 1 after a fill


def swing(beats, seed) -> Song:
    """Jazz: a ride on every beat and the swung eighth, hi-hat pedal on 2 and 4, a feathered kick,
    a walking bass (a note a beat) and piano comping off the beat (the and of 2, beat 4)."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 4):
        chord = SECOND[bar % 4]
        walk = (0, chord[2], chord[3], chord[3] + 2)
        for k, at in enumerate(times[:4]):
            period = times[k + 1] - at
            band.drum("ride", at, 0.35)
            if k % 2 == 1:
                band.drum("ride", at + 2 / 3 * period, 0.25)
                band.drum("hat", at, 0.3)
            band.drum("kick", at, 0.15)
            band.bass(at, chord[0], walk[k], period, 0.55)
        band.chord(times[1] + 2 / 3 * (times[2] - times[1]), chord, 0.4, 0.22, bright=0.6)
        band.chord(times[3], chord, 0.3, 0.2, bright=0.6)
    return band.song("swing 132", beats, beats[::4], "4/4")


def funk(beats, seed) -> Song:
    """Sixteenth hats, a syncopated kick (1, the a of 1, the and of 3), snare 2 and 4 with ghost
    notes, a syncopated bass and chord stabs on the e of 2 and the and of 4."""
    band = Band(beats[-1] + 2, seed)
    bass_at = ((0, 0), (3, 12), (6, 10), (8, 7), (11, 0), (14, 12))  # (sixteenth, semitones)
    for bar, times in bars_of(beats, 4):
        chord = (("E", 0, 3, 7, 10), ("A", 0, 4, 7, 10))[bar % 2]
        sixteenths = np.concatenate(
            [np.linspace(a, b, 4, endpoint=False) for a, b in zip(times, times[1:])]
        )
        for s, at in enumerate(sixteenths):
            band.drum("hat", at, 0.25 if s % 4 == 0 else 0.12)
            if s in (4, 12):
                band.drum("snare", at, 0.7)
            elif s % 4 == 3:
                band.drum("snare", at, 0.08)  # ghost notes
        for s, gain in ((0, 0.8), (3, 0.45), (10, 0.65)):
            band.drum("kick", sixteenths[s], gain)
        for s, semitones in bass_at:
            band.bass(sixteenths[s], chord[0], semitones, 0.14, 0.5 if s else 0.6)
        for s in (5, 14):
            band.chord(sixteenths[s], chord, 0.1, 0.14, bright=0.7)
    return band.song("funk 100", beats, beats[::4], "4/4")


def compound(beats, seed) -> Song:
    """6/8: two dotted-quarter beats of three eighths; kick on 1, snare on 4, an arpeggio."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 2):
        chord = PROGRESSION[bar % 4]
        for k, at in enumerate(times[:2]):
            eighth = (times[k + 1] - at) / 3
            band.drum("kick" if k == 0 else "snare", at, 0.7 if k == 0 else 0.45)
            for e in range(3):
                band.drum("hat", at + e * eighth, 0.25 if e == 0 else 0.15)
                semitones = chord[1:][(3 * k + e) % (len(chord) - 1)]
                band.play(at + e * eighth, note(pitch_hz(chord[0], semitones, 4), 0.3), 0.15, 2)
        band.bass(times[0], chord[0], 0, times[2] - times[0])
    return band.song("6/8 at 70", beats, beats[::2], "6/8")


def additive(beats, seed) -> Song:
    """7/8 as 2+2+3 eighths: kick on each group's first, snare on the third group, hats on the
    eighths, bass a bar and a chord on each group."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 7):
        chord = PROGRESSION[bar % 4]
        for k, at in enumerate(times[:7]):
            band.drum("hat", at, 0.25)
            if k in (0, 2):
                band.drum("kick", at, 0.8 if k == 0 else 0.55)
            if k == 4:
                band.drum("snare", at, 0.55)
            if k in (0, 2, 4):
                band.chord(at, chord, 0.25, 0.12)
        band.bass(times[0], chord[0], 0, times[7] - times[0])
    return band.song("7/8 2+2+3 eighths 180", beats, beats[::7], "7/8")


def five(beats, seed) -> Song:
    """5/4 as 3+2: kick on 1 and 4, snare on 3 and 5, a chord on 1 and a stab on 4."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 5):
        chord = SECOND[bar % 4]
        for k, at in enumerate(times[:5]):
            period = times[k + 1] - at
            band.drum("ride", at, 0.3)
            band.drum("ride", at + 2 / 3 * period, 0.2)
            if k in (0, 3):
                band.drum("kick", at, 0.7 if k == 0 else 0.5)
            if k in (2, 4):
                band.drum("snare", at, 0.45)
        band.chord(times[0], chord, 0.6, 0.2)
        band.chord(times[3], chord, 0.3, 0.25, bright=0.7)
        band.bass(times[0], chord[0], 0, times[3] - times[0])
        band.bass(times[3], chord[0], 7, times[5] - times[3])
    return band.song("5/4 at 168", beats, beats[::5], "5/4")


def piano(beats, seed) -> Song:
    """Rubato piano alone: a bass note on each bar's 1 and the chord broken over the beats."""
    band = Band(beats[-1] + 3, seed)
    for bar, times in bars_of(beats, 3):
        chord = PROGRESSION[bar % 4]
        band.bass(times[0], chord[0], 0, times[3] - times[0], 0.6)
        for k, at in enumerate(times[:3]):
            band.chord(at, (chord[0], *chord[1 + (k > 0) :]), times[k + 1] - at, 0.15 if k else 0.2)
    return band.song("rubato piano 3/4", beats, beats[::3], "3/4", tempo_bpm=float("nan"))


def breakdown(beats, seed) -> Song:
    """8 bars of the band, 4 of pads and a bass note a bar only, 8 of the band again."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 4):
        if 8 <= bar < 12:
            band.pad(times[0], PROGRESSION[bar % 4], times[4] - times[0] + 0.2)
            band.bass(times[0], PROGRESSION[bar % 4][0], 0, times[4] - times[0], 0.3)
        else:
            rock_bar(band, times, bar)
    return band.song("breakdown 124", beats, beats[::4], "4/4")


def intro(beats, seed) -> Song:
    """4 bars of piano chords on the beats (no drums), then the band."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 4):
        if bar < 4:
            chord = PROGRESSION[bar % 4]
            band.bass(times[0], chord[0], 0, times[4] - times[0], 0.4)
            for k, at in enumerate(times[:4]):
                band.chord(at, chord, times[k + 1] - at, 0.14 if k else 0.18)
        else:
            rock_bar(band, times, bar)
    return band.song("drumless intro 110", beats, beats[::4], "4/4")


def dnb(beats, seed) -> Song:
    """Drum'n'bass: kick on 1 and the and of 3, a loud snare on 2 and 4, eighth hats, a bass a
    bar and pads."""
    band = Band(beats[-1] + 2, seed)
    for bar, times in bars_of(beats, 4):
        chord = SECOND[(bar // 2) % 4]
        for k, at in enumerate(times[:4]):
            period = times[k + 1] - at
            band.drum("hat", at, 0.25)
            band.drum("hat", at + period / 2, 0.18)
            if k in (1, 3):
                band.drum("snare", at, 0.9)
        band.drum("kick", times[0], 0.8)
        band.drum("kick", times[2] + (times[3] - times[2]) / 2, 0.7)
        band.bass(times[0], chord[0], 0, times[4] - times[0], 0.5)
        if bar % 2 == 0:
            band.pad(times[0], chord, 2 * (times[4] - times[0]), 0.1)
    return band.song("drum'n'bass 174", beats, beats[::4], "4/4")


def ballad(beats, seed) -> Song:
    """60 BPM: a soft kick on 1, a rim on 2 and 4, piano in eighths (which is where 120 comes
    from), a bass a bar."""
    band = Band(beats[-1] + 3, seed)
    for bar, times in bars_of(beats, 4):
        chord = PROGRESSION[bar % 4]
        band.bass(times[0], chord[0], 0, times[4] - times[0], 0.5)
        for k, at in enumerate(times[:4]):
            period = times[k + 1] - at
            if k == 0:
                band.drum("kick", at, 0.6)
            if k in (1, 3):
                band.drum("snare", at, 0.25)
            for e in range(2):
                semitones = chord[1:][(2 * k + e) % (len(chord) - 1)]
                band.play(at + e * period / 2, note(pitch_hz(chord[0], semitones, 4), 0.6), 0.14, 2)
    return band.song("ballad 60", beats, beats[::4], "4/4")


def issue_songs() -> list[Song]:
    steady = lambda bpm: lambda t: bpm  # noqa: E731
    ramp = lambda t: 90 + 40 * min(max((t - 2) / 36, 0), 1)  # noqa: E731
    rubato = lambda t: 84 * (1 + 0.08 * np.sin(2 * np.pi * t / 9))  # noqa: E731
    gap_s = 3.0  # 3 s of silence after 8 bars: 5.8 beats at 116, so the bars restart after it
    first = beat_times(steady(116), 0.4, 0.4 + 32 * 60 / 116 - 0.01)
    after = first[-1] + 60 / 116 + gap_s + np.arange(48) * 60 / 116
    silence = rock("3 s silence 116", np.concatenate([first, after]), 13)
    silence.downbeats_s = np.concatenate([first[::4], after[::4]])
    ramp_song = rock("accelerando 90->130", beat_times(ramp, 0.3, 44), 6)
    ramp_song.tempo_bpm = float("nan")
    return [
        swing(beat_times(steady(132), 0.3, 30), 1),
        funk(beat_times(steady(100), 0.3, 32), 2),
        compound(beat_times(steady(70), 0.3, 30), 3),
        additive(beat_times(steady(180), 0.3, 30), 4),
        five(beat_times(steady(168), 0.3, 30), 5),
        ramp_song,
        piano(beat_times(rubato, 0.5, 32), 7),
        breakdown(beat_times(steady(124), 0.3, 0.3 + 80 * 60 / 124), 8),
        intro(beat_times(steady(110), 0.5, 34), 9),
        rock("fills 120", beat_times(steady(120), 0.3, 33), 10, fills=True),
        dnb(beat_times(steady(174), 0.3, 30), 11),
        ballad(beat_times(steady(60), 1.0, 49), 12),
        silence,
        rock("pickup 104", beat_times(steady(104), 0.4, 32), 14, pickup=2),
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
    parser.add_argument(
        "--set", choices=("issue", "earlier", "all"), default="all", help="which songs to run"
    )
    parser.add_argument("--no-budget", action="store_true", help="skip the 5-minute song")
    parser.add_argument("--budget-child", help=argparse.SUPPRESS)  # samples (.npy) to analyse
    args = parser.parse_args()
    if args.budget_child:
        return budget_child(Path(args.budget_child))
    librosa = require_librosa()
    warm_up = songs()[0].samples[: 5 * RATE_HZ]  # numba compiles on first use: not timed
    detect_beats(Audio(warm_up, RATE_HZ))
    librosa.beat.beat_track(y=warm_up, sr=RATE_HZ)
    neural = beat_this_tracker()
    chosen = {"issue": issue_songs, "earlier": songs}.get(args.set)
    run = chosen() if chosen else songs() + issue_songs()
    header = (
        f"{'song':22} {'tempo err':>9} {'beat F':>6} {'down F':>6} {'meter':>10} {'conf':>5} "
        f"{'time':>6} {'goal':>6} | {'librosa tempo':>13} {'beat F':>6} {'time':>6}"
        + (f" | {'Beat This! tempo':>16} {'beat F':>6} {'down F':>6}" if neural else "")
    )
    print(header)
    print("-" * len(header))
    totals: dict[str, list[float]] = {}
    for song in run:
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
                f"{song.name:22} {verdict:>33} {analysis.confidence:5.2f} {took:5.2f}s {goal:>6} | "
                f"{plain_bpm:7.1f} BPM, {len(plain)} beats {plain_took:5.2f}s"
            )
            continue
        error = _tempo_error(analysis.bpm, song.tempo_bpm)
        plain_error = _tempo_error(plain_bpm, song.tempo_bpm)
        meter = meter_of(analysis)
        beat_f = f_measure(analysis.beats_s, song.beats_s)
        down_f = f_measure(analysis.downbeats_s, song.downbeats_s)
        plain_f = f_measure(plain, song.beats_s)
        met = {
            "steady": beat_f >= 0.95 and down_f >= 0.9,
            "change": beat_f >= 0.9,
            "issue": beat_f >= 0.97 and down_f >= 0.9 and meter == song.meter,
        }.get(song.goal)
        goal = "-" if met is None else "met" if met else "MISSED"
        row = (
            f"{song.name:22} {error:>9} {beat_f:6.2f} {down_f:6.2f} "
            f"{meter + ('' if meter == song.meter else '!'):>6} ({analysis.meter_confidence:.1f})"
            f" {analysis.confidence:5.2f} {took:5.2f}s {goal:>6} | {plain_error:>13} "
            f"{plain_f:6.2f} {plain_took:5.2f}s"
        )
        scores = {
            "beat F": beat_f,
            "downbeat F": down_f,
            "meter right": float(meter == song.meter),
            "tempo within 1 %": _within(analysis.bpm, song.tempo_bpm),
            "librosa beat F": plain_f,
            "librosa tempo within 1 %": _within(plain_bpm, song.tempo_bpm),
        }
        if neural:
            bpm, beats, downbeats = neural(song.samples)
            scores["Beat This! beat F"] = f_measure(beats, song.beats_s)
            scores["Beat This! downbeat F"] = f_measure(downbeats, song.downbeats_s)
            row += (
                f" | {_tempo_error(bpm, song.tempo_bpm):>16} {scores['Beat This! beat F']:6.2f} "
                f"{scores['Beat This! downbeat F']:6.2f}"
            )
        print(row)
        if song.goal == "issue":
            for key, value in scores.items():
                if not np.isnan(value):
                    totals.setdefault(key, []).append(value)
        for warning in analysis.warnings:
            print(f"{'':22} warning: {warning}")
    if totals:
        print("\nthe songs of issue 31 (goals: beat F >= 0.97, downbeat F >= 0.9 on average, meter")
        print("right on every song, tempo within 1 % at the dancer's level):")
        for key, values in totals.items():
            how = f"{sum(values):.0f} of {len(values)}" if "within" in key or "right" in key else ""
            print(f"  {key:26} {how or f'{np.mean(values):.3f} on average'}")
    if not args.no_budget:
        five_minute_budget()
    return 0


BUDGET_SONG_S, BUDGET_S, BUDGET_MB = 300.0, 10.0, 400.0


def five_minute_budget() -> None:
    """The 5-minute song analysed in a fresh process (so the peak memory is the analysis's, not
    the synthesis's or the other songs'), its beats scored here."""
    beats = beat_times(lambda t: 120.0, 0.3, BUDGET_SONG_S)
    song = rock("5 minutes", beats, 15, fills=True)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "song.npy"
        np.save(path, song.samples)
        child = [sys.executable, __file__, "--budget-child", str(path)]
        result = json.loads(
            subprocess.run(child, capture_output=True, text=True, check=True).stdout
        )
    took, cpu, peak = result["took_s"], result["cpu_s"], result["peak_mb"]
    met = "met" if took <= BUDGET_S and peak <= BUDGET_MB else "MISSED"
    print(
        f"\n{BUDGET_SONG_S / 60:.0f}-minute song: detect_beats {took:.1f} s (CPU {cpu:.1f} s), "
        f"peak memory {peak:.0f} MB (goals: {BUDGET_S:.0f} s, {BUDGET_MB:.0f} MB: {met}); "
        f"beat F {f_measure(result['beats_s'], song.beats_s):.2f}, "
        f"downbeat F {f_measure(result['downbeats_s'], song.downbeats_s):.2f}"
    )


def budget_child(path: Path) -> int:
    """Analyse the samples at ``path`` after a warm-up (numba's compiling is not the song's);
    print the time, CPU time, peak resident memory and the beats as JSON."""
    samples = np.load(path)
    detect_beats(Audio(samples[: 5 * RATE_HZ], RATE_HZ))
    began, cpu = time.perf_counter(), time.process_time()
    analysis = detect_beats(Audio(samples, RATE_HZ))
    took, cpu = time.perf_counter() - began, time.process_time() - cpu
    peak_mb = _peak_resident_mb()
    print(
        json.dumps(
            {
                "took_s": took,
                "cpu_s": cpu,
                "peak_mb": peak_mb,
                "beats_s": analysis.beats_s,
                "downbeats_s": analysis.downbeats_s,
            }
        )
    )
    return 0


def meter_of(analysis) -> str:
    """The meter as a time signature: ``analysis.meter`` where the detector tells one."""
    return getattr(analysis, "meter", f"{analysis.beats_per_bar}/4")


def beat_this_tracker():
    """Beat This! (``pip install beat-this``, with torch and its weights) as (bpm, beats,
    downbeats) of samples at RATE_HZ, or None when it is not installed or has no weights."""
    try:
        from beat_this.inference import Audio2Beats
    except ImportError:
        return None
    try:
        tracker = Audio2Beats(checkpoint_path="final0", device="cpu", dbn=False)
    except Exception as error:  # noqa: BLE001 - its weights come from the network
        print(f"Beat This! is installed but cannot load its weights: {error}")
        return None

    def track(samples):
        beats, downbeats = tracker(samples, RATE_HZ)
        bpm = 60 / float(np.median(np.diff(beats))) if len(beats) > 1 else 0.0
        return bpm, np.asarray(beats), np.asarray(downbeats)

    return track


def _peak_resident_mb() -> float:
    """This process's peak resident memory: VmHWM on Linux (getrusage's ru_maxrss keeps the
    parent's peak across fork and exec: the child of a 500 MB bench would say 500 MB)."""
    status = Path("/proc/self/status")
    if status.exists():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024  # kB
    scale = 1024 * 1024 if sys.platform == "darwin" else 1024  # bytes on macOS, else kB
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / scale


def _tempo_error(bpm: float, truth: float) -> str:
    return "-" if np.isnan(truth) else f"{100 * (bpm - truth) / truth:+.1f}%"


def _within(bpm: float, truth: float) -> float:
    return float("nan") if np.isnan(truth) else float(abs(bpm - truth) <= 0.01 * truth)


if __name__ == "__main__":
    sys.exit(main())
