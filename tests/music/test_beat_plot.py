"""The beat plot: a PNG of the waveform with the beats and downbeats drawn where they are."""

from __future__ import annotations

import numpy as np
from cli_helpers import png_size
from PIL import Image

from choreo.music.beat_plot import HEIGHT_PX, WIDTH_PX, plot_beats
from choreo.music.beats import BeatAnalysis, TempoSpan
from choreo.music.decode import Audio


def test_downbeats_are_drawn_in_red_where_they_fall(tmp_path):
    audio = Audio(np.zeros(4 * 8000, np.float32), 8000)
    analysis = BeatAnalysis(
        duration_s=4.0,
        beats_s=(1.0, 2.0, 3.0),
        downbeats_s=(2.0,),
        beats_per_bar=4,
        tempi=(TempoSpan(1.0, 3.0, 60.0),),
    )
    out = tmp_path / "beats.png"
    plot_beats(audio, analysis, out, "silence")
    assert png_size(out) == (WIDTH_PX, HEIGHT_PX)
    pixels = np.asarray(Image.open(out).convert("RGB")).astype(int)
    red = (pixels[..., 0] > 180) & (pixels[..., 1] < 80) & (pixels[..., 2] < 80)
    columns = np.flatnonzero(red[HEIGHT_PX // 2])
    assert columns.size  # the downbeat line crosses the middle of the plot
    blue = (pixels[..., 2] > 150) & (pixels[..., 0] < 80)
    assert np.flatnonzero(blue[HEIGHT_PX // 2]).size >= 2  # the two other beats
