"""What the timeline draws of a plan, as JSON-ready data (``timeline_state``): keyframes with
the joints each one changes, lanes grouped by limb, the curves, the findings with the keyframe
each one belongs to, and the music's beats and the song's waveform."""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from choreo.motion.music_block import Music
from choreo.studio.session import Plan

log = logging.getLogger(__name__)

CURVE_POINTS = 2000  # samples per joint's curve: a few per pixel of a wide screen
PEAKS_PER_S = 50  # the waveform's resolution: one peak per 20 ms of song
PEAK_RATE_HZ = 8000  # the song is decoded this finely for its waveform


def timeline_state(
    plan: Plan,
    version: int,
    limbs: Sequence[tuple[str, Sequence[int]]],
    peaks: Sequence[int] = (),
) -> dict:
    """Everything the timeline draws of ``plan`` (reload ``version``), as JSON-ready data:
    keyframes with the joints each one changes, the lanes grouped by ``limbs``, the curves,
    the findings with the keyframe each one belongs to, and the music's beats and ``peaks``."""
    motion, robot = plan.motion, plan.motion.robot
    times = plan.keyframe_times_s
    own = Path(motion.path).resolve()
    resolved = functools.cache(lambda path: Path(path).resolve())  # a file per keyframe: once
    keyframes = []
    previous: tuple[float, ...] | None = None
    for keyframe, t in zip(motion.keyframes, times):
        changed = [
            j
            for j, angle in enumerate(keyframe.targets_deg)
            if previous is None or abs(angle - previous[j]) > 1e-6
        ]
        previous = keyframe.targets_deg
        where = keyframe.where
        keyframes.append(
            {
                "t": round(t, 4),
                "where": f"{Path(where.path).name}:{where.line}",
                "label": keyframe.label,
                "joints": changed,
                "editable": resolved(where.path) == own and not where.included_at,
                "pose": {n: round(a, 3) for n, a in zip(robot.joint_names, keyframe.targets_deg)},
            }
        )
    return {
        "version": version,
        "file": Path(motion.path).name,
        "start_s": round(plan.start_s, 4),
        "end_s": round(plan.end_s, 4),
        "keyframes": keyframes,
        "joints": [
            {"name": j.name, "min": j.limits.min_deg, "max": j.limits.max_deg} for j in robot.joints
        ],
        "limbs": [{"name": name, "joints": list(joints)} for name, joints in limbs],
        "curves": _curves(plan),
        "findings": [
            {
                "t": round(f.time_s, 4),
                "duration_s": round(f.duration_s, 4),
                "severity": f.severity.value,
                "message": f.message,
                "keyframe": keyframes[keyframe_of(times, f.time_s)]["where"] if keyframes else "",
            }
            for f in plan.findings
        ],
        "music": _music(motion.music, version, peaks),
    }


def keyframe_of(times_s: Sequence[float], t_s: float) -> int:
    """The keyframe a moment belongs to: the one the motion is moving to (or holding) then."""
    later = int(np.searchsorted(np.asarray(times_s), t_s - 1e-6))
    return min(later, len(times_s) - 1)


def _curves(plan: Plan) -> dict:
    every = max(1, math.ceil(len(plan.times_s) / CURVE_POINTS))
    times = plan.times_s[::every]
    planned = plan.command_deg[::every]
    curves: dict[str, Any] = {
        "t": np.round(times, 4).tolist(),
        "plan": np.round(planned.T, 2).tolist(),
        "sim": None,
    }
    if plan.physics is not None:
        curves["sim"] = np.round(plan.physics.simulated_deg(times).T, 2).tolist()
    return curves


def _music(music: Music | None, version: int, peaks: Sequence[int]) -> dict | None:
    if music is None:
        return None
    grid = music.grid
    return {
        "name": music.song.name,
        "offset_s": music.start_s,
        "beats": [round(t, 4) for t in grid.beat_times_s],
        "beats_per_bar": grid.beats_per_bar,
        "bar_one_beat": grid.bar_one_beat,
        "peaks_per_s": PEAKS_PER_S,
        "peaks": list(peaks),
        "song_url": f"song?v={version}",
    }


def song_peaks(music: Music | None) -> tuple[int, ...]:
    """The song's loudness, 0..100, every 1/PEAKS_PER_S s (nothing if it can't be decoded)."""
    if music is None:
        return ()
    from choreo.errors import ChoreoError
    from choreo.music.decode import decode_song

    try:
        audio = decode_song(music.song, rate_hz=PEAK_RATE_HZ)
    except ChoreoError as error:
        log.warning("no waveform for %s: %s", music.song, error)
        return ()
    samples = np.abs(np.asarray(audio.samples, dtype=float))
    if samples.ndim > 1:
        samples = samples.max(axis=1)
    per = max(1, audio.rate_hz // PEAKS_PER_S)
    count = len(samples) // per
    if count == 0:
        return ()
    peaks = samples[: count * per].reshape(count, per).max(axis=1)
    top = float(peaks.max()) or 1.0
    return tuple(int(round(p)) for p in peaks / top * 100)
