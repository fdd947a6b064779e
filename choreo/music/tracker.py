"""The dynamic-programming beat tracker (Ellis 2007) as librosa 0.11's ``beat.beat_track``
computes it from an onset envelope (untrimmed), without importing ``librosa.beat``.

Importing ``librosa.beat`` compiles one of its functions with numba every time (librosa keeps
that one out of numba's cache): some 3 s of CPU, half of what ``choreo beats`` spends on a short
song. Here the same arithmetic, in the same order, is done with numpy (the dynamic program a
stretch of frames at a time: 0.1 s for a five-minute song). Logarithms and exponentials come
from ``math`` (the C library's, as numba's), so the scores match librosa's to the bit
(tests/music/test_tracker.py compares the beats with librosa's).
"""

from __future__ import annotations

import math

import numpy as np

TIGHTNESS = 100.0  # librosa's default: how strongly the beats keep to the tempo


def track_beats(
    librosa, envelope: np.ndarray, bpm: float | np.ndarray, frame_rate_hz: float
) -> np.ndarray:
    """The frames of the beats in onset ``envelope`` at ``bpm`` (one tempo, or one per frame),
    as ``librosa.beat.beat_track(onset_envelope=..., bpm=..., trim=False)`` finds them."""
    if not envelope.any():
        return np.array([], dtype=int)
    frames_per_beat = np.round(frame_rate_hz * 60.0 / np.atleast_1d(bpm).astype(float))
    spread = envelope.std(ddof=1, axis=-1, keepdims=True)
    onsets = envelope / (spread + librosa.util.tiny(envelope))
    score = local_score(onsets.astype(float), frames_per_beat)
    backlink, cumulative = _best_paths(score, frames_per_beat)
    beats = np.zeros(len(score), dtype=bool)
    frame = _last_beat(librosa, cumulative)
    while frame >= 0:
        beats[frame] = True
        frame = backlink[frame]
    return np.flatnonzero(_untrimmed(beats, score))


def local_score(onsets: np.ndarray, frames_per_beat: np.ndarray) -> np.ndarray:
    """The onsets smoothed by a Gaussian window a beat wide (each frame's own beat, where the
    tempo changes), summed as librosa's loop sums: window index ascending, the first frame
    never counted."""
    count = len(onsets)
    score = np.zeros(count)
    per_frame = np.broadcast_to(frames_per_beat, (count,)) if len(frames_per_beat) > 1 else None
    for width in np.unique(frames_per_beat):
        frames = np.arange(count) if per_frame is None else np.flatnonzero(per_frame == width)
        offsets = np.arange(-width, width + 1) * 32.0 / width
        window = np.array([math.exp(-0.5 * offset**2) for offset in offsets])
        half = len(window) // 2
        for k, weight in enumerate(window):
            source = frames + half - k
            valid = (source >= 1) & (source < count)
            score[frames[valid]] += weight * onsets[source[valid]]
    return score


def _best_paths(score: np.ndarray, frames_per_beat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(backlink, cumulative score) of each frame: the best previous beat half a beat to two
    beats back, penalised by how far its interval is from the beat, in librosa's order (the
    nearest first: the first of equal scores wins). A frame looks back at least half a beat, so
    the frames of each stretch that short are found together."""
    count = len(score)
    width = np.broadcast_to(frames_per_beat, (count,))
    frames = np.arange(count)
    nearest = frames - np.round(width / 2).astype(int)
    farthest = np.maximum(frames - (2 * width).astype(int), 0)
    logs = np.array([-math.inf] + [math.log(gap) for gap in range(1, int(2 * width.max()) + 2)])
    log_width = np.array([math.log(w) for w in width])
    back = np.arange(int(max(1, (nearest - farthest).max() + 1)))  # 0: the nearest
    cumulative = np.zeros(count)
    location = np.full(count, -1)
    stretch = max(1, int(np.round(width / 2).min()))  # frames none of which looks at another
    for begin in range(0, count, stretch):
        block = slice(begin, begin + stretch)
        previous = nearest[block, None] - back
        valid = previous >= farthest[block, None]
        previous = np.where(valid, previous, 0)
        gap_logs = logs[np.where(valid, frames[block, None] - previous, 1)]
        penalty = TIGHTNESS * (gap_logs - log_width[block, None]) ** 2
        scores = np.where(valid, cumulative[previous] - penalty, -math.inf)
        at = np.argmax(scores, axis=1)
        found = valid.any(axis=1)
        rows = np.arange(len(at))
        best = scores[rows, at]
        cumulative[block] = np.where(found, score[block] + best, score[block])
        location[block] = np.where(found, previous[rows, at], -1)
    # librosa links no frame to a beat before the first whose score passes 1 % of the best
    backlink = location.copy()
    passing = np.flatnonzero(score >= 0.01 * score.max())
    backlink[: passing[0] if len(passing) else count] = -1
    return backlink, cumulative


def _last_beat(librosa, cumulative: np.ndarray) -> int:
    """The last local maximum of the cumulative score at least half their median (librosa's)."""
    peak = librosa.util.localmax(cumulative, axis=-1)
    median = np.ma.median(np.ma.masked_array(data=cumulative, mask=~peak), axis=-1)
    threshold = 0.5 * np.ma.getdata(median)
    candidates = np.flatnonzero(peak & (cumulative >= threshold))
    return int(candidates[-1]) if len(candidates) else len(cumulative) - 1


def _untrimmed(beats: np.ndarray, score: np.ndarray) -> np.ndarray:
    """The beats less those at either end where the local score is zero (librosa drops these
    even untrimmed)."""
    kept = beats.copy()
    positive = np.flatnonzero(score > 0)
    if len(positive) == 0:
        return np.zeros_like(beats)
    kept[: positive[0]] = False
    kept[positive[-1] + 1 :] = False
    return kept
