"""``choreo beats``: the tempo, beats and downbeats of a song; optionally a plot."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from choreo.cli import in_flags, report_in_flags
from choreo.cli.arguments import file_path, finite_float, positive_int
from choreo.cli.plan_commands import png_path
from choreo.core.atomic import check_writable
from choreo.music.beats import LEVELS, TRACKERS, BeatAnalysis, detect_beats
from choreo.music.decode import decode_song
from choreo.music.report import beats_report, suggested_music


def register(subparsers) -> None:
    beats = subparsers.add_parser(
        "beats",
        help="detect the tempo, beats and downbeats of a song (needs choreo[music])",
        description="Decode a song (wav, flac, ogg, mp3) and detect its beats: the tempo of "
        "each steady stretch and how sure it is, every beat's time, the meter and the "
        "downbeats (each bar's first beat), and a music: block for a motion. Times are seconds "
        "from the start of the file.",
    )
    beats.add_argument("song", type=file_path, metavar="SONG", help="a wav, flac, ogg or mp3 file")
    beats.add_argument("--json", action="store_true", help="print the analysis as JSON")
    beats.add_argument(
        "--plot", type=png_path, metavar="FILE.png", help="draw the waveform with the beats"
    )
    beats.add_argument(
        "--meter",
        type=positive_int,
        metavar="N",
        help="beats to the bar, for the downbeats (default: estimated, 2 to 7)",
    )
    beats.add_argument(
        "--level",
        choices=LEVELS,
        help="the alternative grid a warning offers: every other beat (half), a beat between "
        "each two (double), three beats in each (triple: a compound meter's eighths) or every "
        "third beat (third)",
    )
    beats.add_argument(
        "--offset-beats",
        type=finite_float,  # its range is detect_beats' to say (OFFSET_BEATS)
        default=0.0,
        metavar="N",
        help="move the grid by N beats (0.5: onto the off-beats)",
    )
    beats.add_argument(
        "--tracker",
        choices=TRACKERS,
        default=TRACKERS[0],
        help="what finds the beats: librosa (the default) or the neural Beat This! (needs "
        "choreo[beats-neural] and torch)",
    )
    beats.set_defaults(handler=run_beats)


def run_beats(args: argparse.Namespace) -> int:
    if args.plot is not None:
        check_writable(args.plot)
    audio = decode_song(args.song)
    analysis = detect_beats(audio, args.meter, args.level or "", args.offset_beats, args.tracker)
    if args.json:
        report = beats_report(args.song, analysis, args.level or "", args.offset_beats)
        print(json.dumps(report_in_flags(report), indent=2))
    else:
        print_beats(args.song, analysis, args.level or "", args.offset_beats)
    if args.plot is not None:
        from choreo.music.beat_plot import plot_beats  # matplotlib: only when a plot is asked for

        plot_beats(audio, analysis, args.plot, title=_headline(args.song, analysis))
        if not args.json:
            print(f"wrote {args.plot}")
    return 0


def _headline(song: Path, analysis: BeatAnalysis) -> str:
    if not analysis.beats_s:
        return f"{song.name}: {analysis.duration_s:.2f} s, no beats found"
    if not analysis.steady:
        return (
            f"{song.name}: {analysis.duration_s:.2f} s, no steady beat: {analysis.unsteady_because}"
        )
    return (
        f"{song.name}: {analysis.duration_s:.2f} s, {analysis.bpm:.2f} BPM, "
        f"{len(analysis.beats_s)} beats, {len(analysis.downbeats_s)} downbeats "
        f"({analysis.beats_per_bar} beats to the bar)"
    )


def _meter_text(analysis: BeatAnalysis) -> str:
    if not analysis.meter_detected:
        return f"meter {analysis.beats_per_bar} beats to the bar (given)"
    sure = "sure" if analysis.meter_confidence >= 0.5 else "unsure: give --meter if you know it"
    return (
        f"meter {analysis.beats_per_bar} beats to the bar (estimated, confidence "
        f"{analysis.meter_confidence:.2f}, {sure})"
    )


def print_beats(song: Path, analysis: BeatAnalysis, level: str = "", offset_beats: float = 0.0):
    print(_headline(song, analysis))
    if not analysis.beats_s:
        print("no beats found")
        return
    for span in analysis.tempi:
        print(
            f"tempo {span.bpm:.2f} BPM from {span.start_s:.3f} s to {span.end_s:.3f} s "
            f"(confidence {span.confidence:.2f})"
        )
    if analysis.change_points_s:
        print("tempo changes at (s): " + " ".join(f"{t:.3f}" for t in analysis.change_points_s))
    print(_meter_text(analysis))
    print("beats (s):     " + " ".join(f"{b:.3f}" for b in analysis.beats_s))
    print("downbeats (s): " + " ".join(f"{b:.3f}" for b in analysis.downbeats_s))
    for warning in analysis.warnings if analysis.steady else ():
        print(f"warning: {in_flags(warning)}")
    suggestion = suggested_music(song, analysis, level, offset_beats)
    if suggestion is None:
        print(
            f"no steady beat ({analysis.unsteady_because}): these beats are not worth "
            "dancing to; time the motion in seconds, or give bpm and start by ear"
        )
    else:
        print(f"for a motion: music: {suggestion}")
