"""Songs: decoding them (ffmpeg, from imageio-ffmpeg), finding their beats (librosa, the
``choreo[music]`` extra, imported only when beats are detected) and plotting the beat grid.

- :mod:`~choreo.music.decode`: :class:`Audio`, :func:`decode_song`, songs muxed into videos;
- :mod:`~choreo.music.beats`: :func:`detect_beats`;
- :mod:`~choreo.music.beat_plot`: the beat grid as a picture.
"""

from __future__ import annotations

from choreo.music.beats import BeatAnalysis, detect_beats
from choreo.music.decode import Audio, decode_song

__all__ = ["Audio", "BeatAnalysis", "decode_song", "detect_beats"]
