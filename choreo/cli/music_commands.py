"""``choreo beats``: the tempo, beats and downbeats of a song; optionally a plot."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from choreo.cli.arguments import positive_int
from choreo.cli.plan_commands import png_path
from choreo.music.beats import BeatAnalysis, detect_beats
from choreo.music.decode import decode


def register(subparsers) -> None:
    beats = subparsers.add_parser(
        "beats",
        help="detect the tempo, beats and downbeats of a song (needs choreo[music])",
        description="Decode a song (wav, flac, ogg, mp3) and detect its beats: the tempo of "
        "each steady stretch, every beat's time and the downbeats (each bar's first beat). "
        "Times are seconds from the start of the file; use them for a motion's music: start.",
    )
    beats.add_argument("song", type=Path, metavar="SONG", help="a wav, flac, ogg or mp3 file")
    beats.add_argument("--json", action="store_true", help="print the analysis as JSON")
    beats.add_argument(
        "--plot", type=png_path, metavar="FILE.png", help="draw the waveform with the beats"
    )
    beats.add_argument(
        "--meter",
        type=positive_int,
        default=4,
        metavar="N",
        help="beats to the bar, for the downbeats (default 4)",
    )
    beats.set_defaults(handler=run_beats)


def run_beats(args: argparse.Namespace) -> int:
    audio = decode(args.song)
    analysis = detect_beats(audio, args.meter)
    if args.json:
        print(json.dumps(beats_report(args.song, analysis), indent=2))
    else:
        print_beats(args.song, analysis)
    if args.plot is not None:
        from choreo.music.beat_plot import plot_beats  # matplotlib: only when a plot is asked for

        plot_beats(audio, analysis, args.plot, title=_headline(args.song, analysis))
        if not args.json:
            print(f"wrote {args.plot}")
    return 0


def beats_report(song: Path, analysis: BeatAnalysis) -> dict:
    return {
        "song": str(song),
        "duration_s": analysis.duration_s,
        "bpm": analysis.bpm,
        "beats_per_bar": analysis.beats_per_bar,
        "tempi": [
            {"start_s": span.start_s, "end_s": span.end_s, "bpm": span.bpm}
            for span in analysis.tempi
        ],
        "beats_s": list(analysis.beats_s),
        "downbeats_s": list(analysis.downbeats_s),
    }


def _headline(song: Path, analysis: BeatAnalysis) -> str:
    return (
        f"{song.name}: {analysis.duration_s:.2f} s, {analysis.bpm:.2f} BPM, "
        f"{len(analysis.beats_s)} beats, {len(analysis.downbeats_s)} downbeats "
        f"({analysis.beats_per_bar} beats to the bar)"
    )


def print_beats(song: Path, analysis: BeatAnalysis) -> None:
    print(_headline(song, analysis))
    if not analysis.beats_s:
        print("no beats found")
        return
    for span in analysis.tempi:
        print(f"tempo {span.bpm:.2f} BPM from {span.start_s:.3f} s to {span.end_s:.3f} s")
    print("beats (s):     " + " ".join(f"{b:.3f}" for b in analysis.beats_s))
    print("downbeats (s): " + " ".join(f"{b:.3f}" for b in analysis.downbeats_s))
    print(f"for a motion: music: {suggested_music(song, analysis)}")


def suggested_music(song: Path, analysis: BeatAnalysis) -> str:
    """A music block that starts on the first downbeat: a fixed tempo if the song keeps one."""
    start = analysis.downbeats_s[0] if analysis.downbeats_s else analysis.beats_s[0]
    tempo = f"bpm: {analysis.bpm:.2f}" if len(analysis.tempi) == 1 else "beats: auto"
    meter = f", meter: {analysis.beats_per_bar}/4" if analysis.beats_per_bar != 4 else ""
    return f"{{song: {song.name}, start: {start:.3f}, {tempo}{meter}}}"
