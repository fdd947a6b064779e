"""Bars: the meter of a song and its downbeats, from its beats and the features around them.

- **The meter** is chosen among 2 to 7 beats to the bar by one test applied alike to each: how
  significantly the position in the bar explains two per-beat cues, in a one-way analysis of
  variance (its F test's p-value, so more positions to the bar cost degrees of freedom and a
  multiple of the true meter never wins by having more of them). The cues are the harmonic
  change over bars (the chroma of the bass band over the ``m`` beats from a beat against the
  ``m`` before it: a chord a bar changes at the bar line, not beat to beat under a walking bass
  or comping) and the drums (kick less snare). Their p-values are combined (Fisher). Each cue
  is standardised against the beats around it, so a quiet intro's bars count like the band's.
- **Downbeats** are decoded as a path through the positions in the bar (Viterbi): each beat's
  cues are scored against what each position looks like in this song (the means at each
  position, learnt from the song with its most likely phase), the position advances by one a
  beat, and may restart anywhere at a cost, for free after a gap in the beats (silence): a
  missing or extra beat, a breakdown or a fill shifts the bars from there on only, not the
  whole song.
- **Compound meters**: a beat whose thirds carry onsets and its half does not is three eighths
  (two such beats to the bar: 6/8). **Additive meters** (5, 7) are reported with their grouping
  (2+2+3), from where the accents fall in the bar.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from choreo.music.features import BASS_FFT, Features, around, standardised

METERS = (2, 3, 4, 5, 6, 7)
SNAP_S = 0.05  # a beat's cues are the envelopes' peaks within this of it
RESTART_COST = 12.0  # log-likelihood: a bar restarting off its count must be this much likelier
GAP = 1.6  # a beat this many median intervals after the one before follows a gap (silence)
COMPOUND = 1.4  # a beat's thirds this much stronger than its half: it is three eighths...
THIRDS = 0.3  # ...if they are at least this strong against the beat itself
BASS_SHARE = 0.01  # the bass band's share of the power below which nothing sounds there
CHORD = 5.0  # a new chord (1 - cosine ~0.5) counts like a kick 2.5 deviations up
NO_CHANGE = 0.02  # harmonic change (1 - cosine) varying less than this is no change at all
NESTED = 10.0  # -log p: a meter must explain this much more than its divisor to be chosen over it
GROUPINGS = {5: ((3, 2), (2, 3)), 7: ((2, 2, 3), (3, 2, 2), (2, 3, 2))}
# Each cue is standardised against the beats around it (a Gaussian of this many beats), not the
# whole song's: see locally_standardised.
LOCAL_BEATS = 16.0


@dataclass(frozen=True)
class Bars:
    beats_per_bar: int
    downbeats: np.ndarray  # indices into the beats
    confidence: float  # 0..1: how far the meter stands out from its rivals (1 when given)
    subdivision: int = 2  # 3: each beat is three eighths (a compound meter)
    grouping: tuple[int, ...] = ()  # an additive meter's groups of beats (2, 2, 3), else ()
    evidence: float = 0.0  # the meter's -log p per bar: how clearly the song has bars at all


@dataclass(frozen=True)
class _Cues:
    chroma: np.ndarray  # (beats, 12): the bass band's pitch classes from each beat to the next
    drums: np.ndarray  # per beat: kick less snare, standardised
    new_notes: np.ndarray  # per beat: pitch classes sounding after it and not before, standardised
    chord: np.ndarray  # per beat: 1 - cosine of its chroma against the beat before's
    kick: np.ndarray
    snare: np.ndarray
    loud: np.ndarray
    after_gap: np.ndarray  # per beat: it follows a gap (a restart costs nothing there)
    has_bass: bool  # the bass band sounds (not a click track)


def find_bars(features: Features, beats: np.ndarray, given: int | None = None) -> Bars:
    """The meter (``given``, or the best of METERS) and the downbeats of ``beats``."""
    cues = _cues(features, beats)
    meters = [m for m in ((given,) if given else METERS) if len(beats) >= 2 * m]
    if not meters:
        return Bars(given or 4, np.arange(0, len(beats), given or 4), 0.0 if not given else 1.0)
    evidence = {m: _meter_evidence(cues, m) for m in meters}
    per_bar = _simplest(cues, evidence, max(evidence, key=evidence.__getitem__))
    related = [m for m in evidence if m != per_bar and (per_bar % m and m % per_bar)]
    rival = max([0.0, *(evidence[m] for m in related)])
    confidence = 1.0 if given else float(np.clip(1 - rival / max(evidence[per_bar], 1e-9), 0, 1))
    positions, templates = _decode(cues, per_bar)
    downbeats = np.flatnonzero(positions == 0)
    return Bars(
        per_bar,
        downbeats,
        confidence,
        _subdivision(features, beats),
        _grouping(templates, per_bar),
        evidence[per_bar] / max(len(beats) / per_bar, 1),
    )


# --- cues --------------------------------------------------------------------------------------
def _cues(features: Features, beats: np.ndarray) -> _Cues:
    fps = features.coarse_fps
    frames = np.clip(np.round(beats * fps).astype(int), 0, features.bass_chroma.shape[1] - 1)
    bounds = np.append(frames, features.bass_chroma.shape[1])
    chroma = np.array(
        [
            features.bass_chroma[:, a:b].mean(axis=1) if b > a else np.zeros(12)
            for a, b in zip(bounds[:-1], bounds[1:])
        ]
    )
    kick = locally_standardised(around(features.low, beats, fps, SNAP_S))
    snare = locally_standardised(around(features.snare, beats, fps, SNAP_S))
    loud = locally_standardised(around(features.rms, beats, fps, SNAP_S))
    intervals = np.diff(beats)
    typical = np.median(intervals) if len(intervals) else 1.0
    after_gap = np.concatenate([[False], intervals > GAP * typical])
    new_notes = locally_standardised(_new_notes(features.chroma, frames))
    drums = locally_standardised(kick - snare)
    chord = _beat_change(features.chroma, bounds)
    # the bass band's power against the whole song's, both as a 1024-point spectrum would see it
    rms = np.median(around(features.rms, beats, fps, SNAP_S))
    bass_share = np.median(chroma.sum(axis=1)) / max((rms * BASS_FFT / 2) ** 2, 1e-12)
    has_bass = bool(bass_share > BASS_SHARE)
    return _Cues(chroma, drums, new_notes, chord, kick, snare, loud, after_gap, has_bass)


def locally_standardised(values: np.ndarray) -> np.ndarray:
    """``values`` less their mean around each beat, over their spread there (Gaussians of
    LOCAL_BEATS beats); the whole song's where it has fewer beats than that.

    Why local: the cues are compared between positions in the bar, and a song's sections differ
    in level more than its beats do. Measured against the whole song, a quiet drumless intro's
    every beat is "soft", its bass on 1 a "kick" unlike the band's, and its bars add up to
    noise: with the band's kicks on 1 and 3 the song read 2/4 (benchmarks/bench_beats.py).
    Measured where they are, a section's downbeats stand out by its own standard (some 2.5
    widths away from a change of level; nearer, the sections blend). Narrower windows follow
    the chords' 4-bar cycle (a waltz read as 6 at 10 beats or fewer); 12 to 24 beats give the
    same bars on every song of the benchmark."""
    import scipy.ndimage

    values = np.asarray(values, dtype=float)
    if len(values) < LOCAL_BEATS:
        return standardised(values)
    mean = scipy.ndimage.gaussian_filter1d(values, LOCAL_BEATS, mode="nearest")
    spread = np.sqrt(
        scipy.ndimage.gaussian_filter1d((values - mean) ** 2, LOCAL_BEATS, mode="nearest")
    )
    floor = 1e-6 * (abs(values.mean()) + 1e-9)
    return np.where(spread > floor, (values - mean) / np.maximum(spread, floor), 0.0)


def _beat_change(chroma: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Per beat: 1 - cosine of the chroma from it to the next beat against the beat before's."""
    means = np.array(
        [
            chroma[:, a:b].mean(axis=1) if b > a else np.zeros(12)
            for a, b in zip(bounds[:-1], bounds[1:])
        ]
    )
    norms = np.linalg.norm(means, axis=1) + 1e-9
    similarity = np.sum(means[1:] * means[:-1], axis=1) / (norms[1:] * norms[:-1])
    return np.concatenate([[0.0], 1 - similarity])


def _new_notes(chroma: np.ndarray, frames: np.ndarray, width: int = 5) -> np.ndarray:
    """Per beat frame: how much the pitch classes rise from the ``width`` frames before it to
    the ``width`` after it (a chord struck: several rise; a bass note or a snare: little)."""
    total = np.hstack([np.zeros((12, 1)), np.cumsum(chroma, axis=1)])
    n = chroma.shape[1]
    after = (total[:, np.minimum(frames + width, n)] - total[:, frames]) / width
    before = (total[:, frames] - total[:, np.maximum(frames - width, 0)]) / width
    return np.maximum(after - before, 0).sum(axis=0)


def harmonic_change(chroma: np.ndarray, per_bar: int) -> np.ndarray:
    """Per beat: 1 - cosine of the bass chroma over the ``per_bar`` beats from it against the
    ``per_bar`` beats before it (0 where either is silent)."""
    sums = np.vstack([np.zeros(12), np.cumsum(chroma, axis=0)])
    n = len(chroma)
    index = np.arange(n)
    after = sums[np.minimum(index + per_bar, n)] - sums[index]
    before = sums[index] - sums[np.maximum(index - per_bar, 0)]
    norms = np.linalg.norm(after, axis=1) * np.linalg.norm(before, axis=1)
    similarity = np.sum(after * before, axis=1) / np.where(norms > 0, norms, 1.0)
    return np.where(norms > 0, 1 - similarity, 0.0)


def _change(cues: _Cues, per_bar: int) -> np.ndarray:
    """The harmonic change over ``per_bar`` beats, standardised; zeros where the harmony never
    changes enough to tell (a click track, drums alone)."""
    change = harmonic_change(cues.chroma, per_bar)
    return locally_standardised(change) if np.std(change) >= NO_CHANGE else np.zeros_like(change)


def _downbeat_cue(cues: _Cues, per_bar: int) -> np.ndarray:
    """Per beat: how much like a downbeat: a new chord (the harmonic change over bars), new
    notes struck, a kick and no snare; with nothing in the bass band (a click track), the louder
    beat. It only picks the phase the templates of ``_decode`` are learnt at.

    The weights are measured, not derived: each cue is standardised where it is (see
    locally_standardised), so a weight means the same in every section, and the harmonic change
    counts half because it is flat where the bass moves every half bar (root and fifth). On the
    benchmark's songs these weights put every phase right, but halving or doubling any one of
    them loses one to four songs (swing, funk, pickup: their cues disagree), and neither ranks
    nor weights from each cue's own evidence did better: what is left for a robust phase is a
    cue that tells a chord from a pitched snare (new notes rise on a snare's beats too)."""
    if not cues.has_bass:
        return cues.loud + CHORD * cues.chord
    return 0.5 * _change(cues, per_bar) + cues.new_notes + cues.drums


# --- the meter ---------------------------------------------------------------------------------
def _meter_evidence(cues: _Cues, per_bar: int) -> float:
    """-log p that the position in a ``per_bar`` bar explains the harmonic change and the drums
    (each an F test; Fisher's combination, so 0 for no evidence)."""
    cues_now = (_change(cues, per_bar), cues.new_notes, cues.drums, cues.loud)
    return -sum(_anova_log_p(values, per_bar) for values in cues_now)


def _simplest(cues: _Cues, evidence: dict[int, float], best: int) -> int:
    """``best``, or its smallest divisor among the meters tried that it doesn't explain the cues
    significantly better than (a 6 whose halves look alike is a 3)."""
    for divisor in sorted(m for m in evidence if m < best and best % m == 0):
        cues_now = (_change(cues, best), cues.new_notes, cues.drums, cues.loud)
        log_p = sum(_nested_log_p(values, divisor, best) for values in cues_now)
        if -log_p < NESTED:
            return divisor
    return best


def _nested_log_p(values: np.ndarray, fewer: int, more: int) -> float:
    """log p that grouping ``values`` by index mod ``more`` explains them no better than by
    index mod ``fewer`` (a divisor of it): the F test of the two nested models."""
    import scipy.stats

    n = len(values)
    if n <= more or not np.any(values):
        return 0.0
    within = {}
    for groups in (fewer, more):
        position = np.arange(n) % groups
        means = np.array([values[position == g].mean() for g in range(groups)])
        within[groups] = float(np.sum((values - means[position]) ** 2))
    if within[more] <= 0:
        return -50.0
    f = ((within[fewer] - within[more]) / (more - fewer)) / (within[more] / (n - more))
    return float(scipy.stats.f.logsf(max(f, 0.0), more - fewer, n - more))


def _anova_log_p(values: np.ndarray, groups: int) -> float:
    """log p of a one-way analysis of variance of ``values`` grouped by index mod ``groups``,
    at the best phase (every phase gives the same groups: the phase is free)."""
    import scipy.stats

    n = len(values)
    if n <= groups or not np.any(values):
        return 0.0
    position = np.arange(n) % groups
    means = np.array([values[position == g].mean() for g in range(groups)])
    counts = np.bincount(position, minlength=groups)
    between = float(np.sum(counts * (means - values.mean()) ** 2))
    within = float(np.sum((values - means[position]) ** 2))
    if within <= 0:
        return -50.0 * groups  # a perfect fit: as sure as it gets, not infinitely
    f = (between / (groups - 1)) / (within / (n - groups))
    return float(scipy.stats.f.logsf(f, groups - 1, n - groups))


# --- the downbeats: a path through the positions in the bar ------------------------------------
def _decode(cues: _Cues, per_bar: int) -> tuple[np.ndarray, np.ndarray]:
    """(each beat's position in its bar, 0 the downbeat; the cues' mean at each position)."""
    x = np.column_stack([_change(cues, per_bar), cues.new_notes, cues.kick, cues.snare, cues.loud])
    n = len(x)
    cue = _downbeat_cue(cues, per_bar)
    phase = int(np.argmax([cue[p::per_bar].mean() for p in range(per_bar)]))
    position = (np.arange(n) - phase) % per_bar
    templates = np.array([x[position == p].mean(axis=0) for p in range(per_bar)])
    spread = np.array([np.mean((x[:, f] - templates[position, f]) ** 2) for f in range(x.shape[1])])
    spread = np.maximum(spread, 0.1)
    emission = -0.5 * np.sum((x[:, None, :] - templates[None, :, :]) ** 2 / spread, axis=2)
    # Viterbi: advancing one position a beat is free; anything else costs RESTART_COST
    score = emission[0].copy()
    back = np.zeros((n, per_bar), dtype=int)
    advance = (np.arange(per_bar) - 1) % per_bar  # the position before each
    for i in range(1, n):
        cost = 0.0 if cues.after_gap[i] else RESTART_COST
        stay = score[advance]
        jump_from = int(np.argmax(score))
        jump = score[jump_from] - cost
        take_jump = jump > stay
        back[i] = np.where(take_jump, jump_from, advance)
        score = np.where(take_jump, jump, stay) + emission[i]
    path = np.zeros(n, dtype=int)
    path[-1] = int(np.argmax(score))
    for i in range(n - 1, 0, -1):
        path[i - 1] = back[i, path[i]]
    return path, templates


# --- compound and additive meters --------------------------------------------------------------
def _subdivision(features: Features, beats: np.ndarray) -> int:
    """3 where the beat's thirds carry onsets and its half does not (three eighths a beat)."""
    if len(beats) < 4:
        return 2
    fps, period = features.coarse_fps, np.diff(beats)
    starts = beats[:-1]

    def strength(fraction: float) -> float:
        return float(np.mean(around(features.onset, starts + fraction * period, fps, 0.02)))

    thirds = min(strength(1 / 3), strength(2 / 3))
    on_beat = strength(0.0)
    return 3 if thirds > COMPOUND * strength(0.5) and thirds > THIRDS * on_beat else 2


def _grouping(templates: np.ndarray, per_bar: int) -> tuple[int, ...]:
    """An additive bar's groups: those whose first beats carry the most kick and chord."""
    if per_bar not in GROUPINGS:
        return ()
    accent = templates[:, 1:].sum(axis=1)  # new notes, kick, snare, loudness: not the change

    def starts(groups: tuple[int, ...]) -> list[int]:
        return list(np.cumsum((0, *groups[:-1])))

    return max(GROUPINGS[per_bar], key=lambda groups: accent[starts(groups)[1:]].mean())
