"""The music of a motion: the ``music:`` block, its beat grid, and beats/bars -> seconds.

A motion's t=0 is ``start`` seconds into the song. With a fixed tempo (``bpm``), beat 1 is at
t=0 and beat n at (n-1)·60/bpm; with ``beats: auto`` beat 1 is the first beat detected at or
after ``start`` (the song's own beats, so a tempo that drifts is followed). Bars are counted from
beat 1, ``meter`` beats each. Keyframes timed by ``beat:``/``bar:`` are resolved to ``t`` when the
file is read, so everything after loading (planner, player, exports) sees plain seconds.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from choreo.core.yaml_source import Entry, Node, Reader, SourceLocation, fmt
from choreo.errors import ChoreoError, OptionError
from choreo.music.decode import check_song_path, decode

MUSIC_KEYS = ("song", "start", "bpm", "meter", "beats")
ON_BEAT_S = 0.001  # a detected beat this close before ``start`` still counts as beat 1


@dataclass(frozen=True)
class BeatGrid:
    """Beat n (1-based) is at ``beat_times_s[n - 1]`` seconds of motion time."""

    beat_times_s: tuple[float, ...]
    beats_per_bar: int

    @property
    def beats(self) -> int:
        return len(self.beat_times_s)

    def time_of(self, beat: float) -> float:
        """Motion time of a (fractional) beat inside the grid: between beats, linearly."""
        if not 1 <= beat <= self.beats:
            raise ValueError(f"beat {beat} is outside 1..{self.beats}")
        return float(np.interp(beat, np.arange(1, self.beats + 1), self.beat_times_s))

    def beat_at(self, t_s: float) -> float:
        """The (fractional) beat at motion time ``t_s``; 0 before beat 1's time is not defined."""
        return float(np.interp(t_s, self.beat_times_s, np.arange(1, self.beats + 1)))

    def bar_and_beat(self, beat: float) -> tuple[int, float]:
        bar, within = divmod(beat - 1, self.beats_per_bar)
        return int(bar) + 1, within + 1

    def beat_of_bar(self, bar: int, beat_in_bar: float = 1.0) -> float:
        return (bar - 1) * self.beats_per_bar + beat_in_bar

    def earliest_whole_beat(self, t_s: float) -> int | None:
        """The first whole beat at or after ``t_s`` (1 ms slack); None past the last beat."""
        later = [n for n, b in enumerate(self.beat_times_s, 1) if b >= t_s - 0.001]
        return later[0] if later else None


@dataclass(frozen=True)
class Music:
    song: Path
    start_s: float  # song time at the motion's t=0
    song_duration_s: float
    grid: BeatGrid
    bpm: float | None  # the written tempo; None with beats: auto
    where: SourceLocation  # the music block

    @property
    def auto(self) -> bool:
        return self.bpm is None


@dataclass(frozen=True)
class BeatRef:
    """How a keyframe's time was written in beats (for messages about it)."""

    grid: BeatGrid
    by_bar: bool  # written as bar (+ beat in bar) rather than an absolute beat

    def describe(self, beat: float) -> str:
        if self.by_bar:
            bar, within = self.grid.bar_and_beat(beat)
            return f"bar {bar}" + (f" beat {fmt(within)}" if within != 1 else "")
        return f"beat {fmt(beat)}"

    def earliest_fix(self, t_s: float) -> str:
        """'beat >= 7 (t 3.000)': the first whole beat at or after ``t_s``, as the file writes
        beats."""
        beat = self.grid.earliest_whole_beat(t_s)
        if beat is None:
            return f"a time of {t_s:.3f} s, past the song's last beat ({self.grid.beats})"
        return f"{self.describe(beat)} or later (t {self.grid.time_of(beat):.3f})"


# --- reading the music block ------------------------------------------------------------------
def read_music(reader: Reader, entry: Entry) -> Music | None:
    """The ``music:`` block of a motion file; problems reported on ``reader``."""
    fields = reader.fields(entry.value, "the music block", MUSIC_KEYS, required=("song",))
    if fields is None or "song" not in fields:
        return None
    song = _read_song(reader, fields["song"])
    start_s = reader.number(fields["start"].value, "start", low=0) if "start" in fields else 0.0
    per_bar = _read_meter(reader, fields["meter"].value) if "meter" in fields else 4
    tempo = _read_tempo(reader, entry.value, fields)
    if song is None or start_s is None or per_bar is None or tempo is None:
        return None
    try:
        audio = decode(song)
    except ChoreoError as error:
        reader.report(fields["song"].value, str(error))
        return None
    if start_s >= audio.duration_s:
        reader.report(
            fields["start"].value,
            f"start {fmt(start_s)} is past the end of {song.name} "
            f"({audio.duration_s:.3f} s); give a time inside the song",
        )
        return None
    bpm = tempo if isinstance(tempo, float) else None  # else "auto"
    try:
        beat_times = _beat_times(audio, start_s, bpm, per_bar)
    except ChoreoError as error:
        reader.report(fields["beats"].value, str(error))
        return None
    return Music(
        song,
        start_s,
        audio.duration_s,
        BeatGrid(beat_times, per_bar),
        bpm,
        reader.where(entry.key_node),
    )


def _read_song(reader: Reader, entry: Entry) -> Path | None:
    relative = reader.string(entry.value, "song")
    if relative is None:
        return None
    path = reader.path.parent / relative
    problem = check_song_path(path)
    if problem:
        reader.report(entry.value, f"song: {problem} (paths are relative to this file's folder)")
        return None
    return path


def _read_meter(reader: Reader, node: Node) -> int | None:
    text = reader.string(node, "meter")
    if text is None:
        return None
    top, _, bottom = text.partition("/")
    if top.strip().isdigit() and bottom.strip() in ("2", "4", "8", "16") and int(top) >= 1:
        return int(top)
    reader.report(node, f"meter {text!r} is not a time signature; write it like 4/4, 3/4 or 6/8")
    return None


def _read_tempo(reader: Reader, node: Node, fields: dict[str, Entry]) -> float | str | None:
    """The bpm, or "auto" for detected beats; exactly one of the two must be given."""
    if ("bpm" in fields) == ("beats" in fields):
        where = fields["beats"].key_node if "beats" in fields else node
        reader.report(
            where,
            "the music block needs exactly one of bpm (a fixed tempo, beats per minute) and "
            "beats: auto (the beats detected in the song)",
        )
        return None
    if "bpm" in fields:
        return reader.number(fields["bpm"].value, "bpm", low=0, low_open=True, high=1000)
    return reader.choice(fields["beats"].value, "beats", ("auto",))


def _beat_times(audio, start_s: float, bpm: float | None, per_bar: int) -> tuple[float, ...]:
    if bpm is not None:
        period = 60.0 / bpm
        count = math.floor((audio.duration_s - start_s) / period - 1e-9) + 1  # inside the song
        return tuple(k * period for k in range(count))
    from choreo.music.beats import detect_beats

    beats = detect_beats(audio, per_bar).beats_s
    times = tuple(b - start_s for b in beats if b >= start_s - ON_BEAT_S)
    if not times:
        raise ChoreoError(f"no beats were detected after start {fmt(start_s)} s of the song")
    return tuple(max(t, 0.0) for t in times)


def check_speed(music: Music | None, speed: float | None) -> None:
    """Refuse a speed that would play the motion out of step with its song."""
    if music is not None and speed is not None and speed != 1.0:
        raise OptionError(
            "speed",
            f"{fmt(speed)} would leave {music.song.name} behind (the song plays at its own "
            "tempo); keep {option} 1 with a song",
        )


def music_text(music: Music, motion_path: Path) -> str:
    """The music block as a YAML flow mapping for a motion file written at ``motion_path`` (the
    song's path made relative to it). Keyframes written with it are in seconds (``t``)."""
    song = Path(os.path.relpath(music.song.resolve(), motion_path.resolve().parent)).as_posix()
    tempo = f"bpm: {fmt(music.bpm)}" if music.bpm is not None else "beats: auto"
    meter = f", meter: {music.grid.beats_per_bar}/4" if music.grid.beats_per_bar != 4 else ""
    return f"{{song: {json.dumps(song)}, start: {fmt(music.start_s)}, {tempo}{meter}}}"


# --- keyframe times written in beats ----------------------------------------------------------
def read_beat_time(
    reader: Reader, fields: dict[str, Entry], music: Music | None
) -> tuple[float, BeatRef] | None:
    """The motion time of a keyframe's ``beat:``/``bar:`` (at least one present), or None
    (reported): a beat inside the song, a bar's beat inside the bar."""
    anchor = fields["beat"] if "beat" in fields else fields["bar"]
    if music is None:
        reader.report(
            anchor.key_node,
            f"{anchor.key} needs a music block (music: with song and bpm or beats: auto) in "
            "this motion or the one including it; or time the keyframe with t or after",
        )
        return None
    grid = music.grid
    by_bar = "bar" in fields
    bar = reader.integer(fields["bar"].value, "bar", low=1) if by_bar else None
    beat = (
        reader.number(
            fields["beat"].value,
            "beat",
            low=1,
            high=grid.beats_per_bar if by_bar else None,
        )
        if "beat" in fields
        else 1.0
    )
    if beat is None or (by_bar and bar is None):
        return None
    absolute = grid.beat_of_bar(bar, beat) if bar is not None else beat
    ref = BeatRef(grid, by_bar)
    if absolute > grid.beats:
        last_bar, last_in_bar = grid.bar_and_beat(grid.beats)
        reader.report(
            anchor.value,
            f"{ref.describe(absolute)} is past the end of the song: {music.song.name} has "
            f"{grid.beats} beats after start {fmt(music.start_s)} s (the last is beat "
            f"{grid.beats}, bar {last_bar} beat {fmt(last_in_bar)}, at t "
            f"{grid.beat_times_s[-1]:.3f}); give an earlier beat",
        )
        return None
    return grid.time_of(absolute), ref
