"""A picture of a song's beats: the waveform with every beat and downbeat marked.

Drawn with matplotlib's Agg canvas directly, like ``plot.py`` (no pyplot, no display).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from choreo.core.atomic import atomic_output
from choreo.music.beats import BeatAnalysis
from choreo.music.decode import Audio

DPI = 100
WIDTH_PX, HEIGHT_PX = 1400, 360
WAVE_COLOR = "#888888"
BEAT_COLOR = "#1f77b4"
DOWNBEAT_COLOR = "#d62728"
ENVELOPE_POINTS = 4000  # the waveform is drawn as a min/max envelope of this many columns


def plot_beats(audio: Audio, analysis: BeatAnalysis, path: Path, title: str = "") -> None:
    """Write a PNG: the waveform (min/max envelope), beats in blue, downbeats in red."""
    # matplotlib (a second to import) only when a picture is drawn: a module that only reads
    # the picture's size in pixels does without it
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(WIDTH_PX / DPI, HEIGHT_PX / DPI), dpi=DPI)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    times, low, high = _envelope(audio.mono, audio.rate_hz)
    axes.fill_between(times, low, high, color=WAVE_COLOR, linewidth=0)
    axes.vlines(analysis.beats_s, -1, 1, colors=BEAT_COLOR, linewidth=0.8, label="beat")
    axes.vlines(analysis.downbeats_s, -1, 1, colors=DOWNBEAT_COLOR, linewidth=1.6, label="downbeat")
    axes.set_xlim(0, max(audio.duration_s, 1e-3))
    axes.set_ylim(-1, 1)
    axes.set_xlabel("song time (s)")
    axes.set_yticks([])
    axes.legend(loc="upper right")
    axes.set_title(title, loc="left")
    figure.tight_layout()
    with atomic_output(path) as temporary:
        figure.savefig(temporary, format="png", dpi=DPI)


def _envelope(samples: np.ndarray, rate_hz: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    columns = max(1, min(ENVELOPE_POINTS, len(samples)))
    usable = len(samples) // columns * columns
    if usable == 0:
        return np.zeros(1), np.zeros(1), np.zeros(1)
    blocks = samples[:usable].reshape(columns, -1)
    times = (np.arange(columns) + 0.5) * blocks.shape[1] / rate_hz
    return times, blocks.min(axis=1), blocks.max(axis=1)
