"""The report of a song's beat analysis: its tempo stretches, meter, beats and downbeats, how
sure the detector is, and the ``music:`` block it suggests for a motion; what ``choreo beats``
prints and ``choreo beats --json`` writes."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from choreo.core.arguments import check_path, check_type
from choreo.music.beats import BeatAnalysis, check_grid


def beats_report(
    song: str | os.PathLike[str], analysis: BeatAnalysis, level: str = "", offset_beats: float = 0.0
) -> dict[str, Any]:
    """The analysis as plain JSON-ready values (``choreo beats --json``), with the ``music:``
    block it suggests for a motion (None when the song has no steady beat)."""
    song = check_path("song", song, "the song's path")
    check_type("analysis", analysis, BeatAnalysis, "a BeatAnalysis (from detect_beats)")
    check_grid(level, offset_beats)
    found = bool(analysis.beats_s)  # silence has no tempo, and no meter unless one was given
    meter_known = found or not analysis.meter_detected
    return {
        "song": str(song),
        "duration_s": analysis.duration_s,
        "steady": analysis.steady,
        "unsteady_because": analysis.unsteady_because,
        "confidence": analysis.confidence,
        "bpm": analysis.bpm if found else None,
        "beats_per_bar": analysis.beats_per_bar if meter_known else None,
        "meter_detected": analysis.meter_detected,
        "meter_confidence": analysis.meter_confidence if meter_known else None,
        "tempi": [
            {
                "start_s": span.start_s,
                "end_s": span.end_s,
                "bpm": span.bpm,
                "confidence": span.confidence,
            }
            for span in analysis.tempi
        ],
        "change_points_s": list(analysis.change_points_s),
        "warnings": list(analysis.warnings),
        "beats_s": list(analysis.beats_s),
        "downbeats_s": list(analysis.downbeats_s),
        "music": suggested_music(song, analysis, level, offset_beats),
    }


def suggested_music(
    song: Path, analysis: BeatAnalysis, level: str = "", offset_beats: float = 0.0
) -> str | None:
    """A music block that starts on the first downbeat: a fixed tempo if the song keeps one;
    None if the song has no steady beat."""
    if not analysis.steady:
        return None
    start = analysis.downbeats_s[0] if analysis.downbeats_s else analysis.beats_s[0]
    if len(analysis.tempi) == 1:
        tempo = f"bpm: {analysis.bpm:.2f}"
    else:
        tempo = "beats: auto" + (f", level: {level}" if level else "")
        tempo += f", offset_beats: {offset_beats:g}" if offset_beats else ""
    meter = f", meter: {analysis.beats_per_bar}/4" if analysis.beats_per_bar != 4 else ""
    return f"{{song: {song.name}, start: {start:.3f}, {tempo}{meter}}}"
