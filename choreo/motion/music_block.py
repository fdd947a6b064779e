"""The music of a motion: the ``music:`` block, its beat grid, and beats/bars -> seconds.

A motion's t=0 is ``start`` seconds into the song. With a fixed tempo (``bpm``), beat 1 is at
t=0 and beat n at (n-1)·60/bpm, bars counted from beat 1. With ``beats: auto`` (the song's own
beats, so a tempo that drifts is followed) beat 1 is the detected beat nearest ``start`` (within
half a beat; t=0 moves onto it) and bar 1 starts on the detected downbeat nearest beat 1; the
meter is estimated unless given. Keyframes timed by ``beat:``/``bar:`` are resolved to ``t`` when
the file is read, so everything after loading (planner, player, exports) sees plain seconds.

``repeat`` with music: each repetition starts on the first bar line at least a beat after the
previous one's last keyframe, and its keyframes land on the same beats of their bars as the
first repetition's (following the song's beats, not copying the first repetition's seconds).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from choreo.core.yaml_source import Entry, Node, Reader, SourceLocation, fmt
from choreo.errors import ChoreoError, OptionError
from choreo.motion.timing import TimedKeyframe

MUSIC_KEYS = ("song", "start", "bpm", "meter", "beats", "level", "offset_beats")
DEFAULT_METER = 4


@dataclass(frozen=True)
class BeatGrid:
    """Beat n (1-based) is at ``beat_times_s[n - 1]`` seconds of motion time."""

    beat_times_s: tuple[float, ...]
    beats_per_bar: int
    bar_one_beat: int = 1  # the beat bar 1 starts on (<= 0: before the motion's t=0)

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

    def time_past_end(self, beat: float) -> float:
        """Like ``time_of``, and past the last beat on at the last beats' pace (for a dance
        allowed to outlast its song)."""
        if beat <= self.beats or self.beats < 2:
            return self.time_of(min(beat, self.beats))
        last = self.beat_times_s[-1] - self.beat_times_s[-2]
        return self.beat_times_s[-1] + (beat - self.beats) * last

    def bar_and_beat(self, beat: float) -> tuple[int, float]:
        bar, within = divmod(beat - self.bar_one_beat, self.beats_per_bar)
        return int(bar) + 1, within + 1

    def beat_of_bar(self, bar: int, beat_in_bar: float = 1.0) -> float:
        return self.bar_one_beat - 1 + (bar - 1) * self.beats_per_bar + beat_in_bar

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
    note: str = ""  # beats: auto: which detected beat and downbeat were taken, the meter
    level: str = ""  # beats: auto: "half", "double" or "" (the detected beats)
    offset_beats: float = 0.0  # beats: auto: the grid moved by this many beats

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
    # choreo.music (decoding, beat tracking) is imported only by a motion that has music: a
    # dance without it is planned without loading it (start-up of every ``choreo plan``)
    from choreo.music.decode import decode_song

    song = _read_song(reader, fields["song"])
    start_s = reader.number(fields["start"].value, "start", low=0) if "start" in fields else 0.0
    per_bar = _read_meter(reader, fields["meter"].value) if "meter" in fields else None
    tempo = _read_tempo(reader, entry.value, fields)
    grid_choice = _read_grid_choice(reader, fields, tempo)
    if song is None or start_s is None or tempo is None or grid_choice is None:
        return None
    if "meter" in fields and per_bar is None:
        return None
    try:
        audio = decode_song(song)
    except ChoreoError as error:
        reader.report(fields["song"].value, str(error))
        return None
    if start_s >= audio.duration_s:
        reader.report(
            fields["start"].value if "start" in fields else fields["song"].value,
            f"start {fmt(start_s)} is past the end of {song.name} "
            f"({audio.duration_s:.3f} s); give a time inside the song"
            if "start" in fields
            else f"{song.name} has no sound ({audio.duration_s:.3f} s long); give a song",
        )
        return None
    where = reader.where(entry.key_node)
    if isinstance(tempo, float):
        grid = _fixed_grid(audio.duration_s, start_s, tempo, per_bar or DEFAULT_METER)
        return Music(song, start_s, audio.duration_s, grid, tempo, where)
    try:
        start_s, grid, note = _detected_grid(audio, start_s, per_bar, *grid_choice)
    except ChoreoError as error:
        reader.report(fields["beats"].value, str(error))
        return None
    return Music(song, start_s, audio.duration_s, grid, None, where, note, *grid_choice)


def _read_grid_choice(
    reader: Reader, fields: dict[str, Entry], tempo: float | str | None
) -> tuple[str, float] | None:
    """(level, offset_beats) of ``beats: auto``: the alternative grid ``choreo beats`` offers."""
    from choreo.music.beats import LEVELS, OFFSET_BEATS  # with music only (see read_music)

    given = [fields[k] for k in ("level", "offset_beats") if k in fields]
    if given and tempo is not None and tempo != "auto":
        reader.report(given[0].key_node, f"{given[0].key} goes with beats: auto, not bpm")
        return None
    level = reader.choice(fields["level"].value, "level", LEVELS) if "level" in fields else ""
    bounds = OFFSET_BEATS
    offset = (
        reader.number(
            fields["offset_beats"].value,
            "offset_beats",
            low=bounds.at_least,
            high=bounds.at_most,
            unit=bounds.unit,
        )
        if "offset_beats" in fields
        else 0.0
    )
    if level is None or offset is None:
        return None
    return level, offset


def _read_song(reader: Reader, entry: Entry) -> Path | None:
    from choreo.music.decode import check_song_path  # with music only (see read_music)

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


def _fixed_grid(duration_s: float, start_s: float, bpm: float, per_bar: int) -> BeatGrid:
    period = 60.0 / bpm
    count = math.floor((duration_s - start_s) / period - 1e-9) + 1  # inside the song
    return BeatGrid(tuple(k * period for k in range(count)), per_bar)


def _detected_grid(
    audio, start_s: float, per_bar: int | None, level: str, offset_beats: float
) -> tuple[float, BeatGrid, str]:
    """(the start moved onto beat 1, the grid, what was taken) from the song's detected beats."""
    from choreo.music.beats import detect_beats

    analysis = detect_beats(audio, per_bar, level, offset_beats)
    if not analysis.steady:
        raise ChoreoError(
            f"the song has no steady beat to count ({analysis.unsteady_because}; "
            "choreo beats SONG shows what was found): give bpm and start by ear instead"
        )
    beats = np.asarray(analysis.beats_s)
    nearest = int(np.argmin(np.abs(beats - start_s)))
    interval = float(np.diff(beats)[min(nearest, len(beats) - 2)])
    if abs(beats[nearest] - start_s) <= interval / 2:  # t=0 moves onto it
        first, start_s = nearest, float(beats[nearest])
        how = f"the beat detected at {start_s:.3f} s, nearest start"
    else:  # start falls in a stretch without beats (an intro): the first beat after it
        later = np.flatnonzero(beats >= start_s)
        if len(later) == 0:
            raise ChoreoError(f"no beats were detected after start {fmt(start_s)} s of the song")
        first = int(later[0])
        how = f"the first beat detected after start, at {beats[first]:.3f} s"
    # bar 1: the downbeat nearest beat 1, or the next one if that comes before beat 1
    downbeats = np.asarray(analysis.downbeats_s)
    down = downbeats[downbeats >= beats[first] - 0.001] if len(downbeats) else downbeats
    bar_one = 1 if len(down) == 0 else int(np.argmin(np.abs(beats - down[0]))) - first + 1
    meter = (
        f"{analysis.beats_per_bar} beats to the bar (estimated, confidence "
        f"{analysis.meter_confidence:.2f}; give meter: to fix it)"
        if analysis.meter_detected
        else f"{analysis.beats_per_bar} beats to the bar"
    )
    bar_text = "on it" if bar_one == 1 else f"on beat {bar_one}"
    note = f"beats: auto: beat 1 is {how}; bar 1 starts {bar_text}; {meter}"
    times = tuple(float(b) - start_s for b in beats[first:])
    return start_s, BeatGrid(times, analysis.beats_per_bar, bar_one), note


def repetition_beats(music: Music, keyframes: Sequence[TimedKeyframe]) -> float:
    """Beats from one repetition's first keyframe to the next's: whole bars, the next starting
    at least a beat after the last keyframe is left."""
    grid = music.grid
    first = grid.beat_at(_first_t(keyframes))
    span = grid.beat_at(left_at_s(keyframes)) - first
    return grid.beats_per_bar * math.ceil((span + 1) / grid.beats_per_bar - 1e-9)


def repetition_clock(
    music: Music | None, keyframes: Sequence[TimedKeyframe]
) -> Callable[[float, int], float] | None:
    """For ``played_keyframes``: file time -> motion time in a later repetition, on the song's
    beats (None without music)."""
    if music is None or not keyframes:
        return None
    grid, period = music.grid, repetition_beats(music, keyframes)
    return lambda t_s, rep: grid.time_past_end(grid.beat_at(t_s) + rep * period)


def past_song(music: Music | None, keyframes: Sequence[TimedKeyframe], repeat: int) -> str | None:
    """Why the dance would outlast its song (one phrase), or None. Keyframes reached as soon as
    the limits allow count as taking no time, so this is the least it runs."""
    if music is None or not keyframes:
        return None
    song_left_s = music.song_duration_s - music.start_s
    end_s = left_at_s(keyframes)
    if repeat > 1:
        clock = repetition_clock(music, keyframes)
        assert clock is not None
        end_s = clock(end_s, repeat - 1)
    if end_s <= song_left_s:
        return None
    times = f" (repeat {repeat})" if repeat > 1 else ""
    return (
        f"the dance{times} runs to at least t {end_s:.3f} s, {end_s - song_left_s:.3f} s past "
        f"the end of {music.song.name} (which ends at t {song_left_s:.3f} after start "
        f"{fmt(music.start_s)} s)"
    )


def left_at_s(keyframes: Sequence[TimedKeyframe]) -> float:
    """When the last keyframe is left (reached and held), as far as the file's times say."""
    time_s = 0.0
    for kf in keyframes:
        time_s = kf.t_s if kf.t_s is not None else time_s + (kf.after_s or 0.0)
        time_s += kf.hold_s
    return time_s


def _first_t(keyframes: Sequence[TimedKeyframe]) -> float:
    first = keyframes[0]
    return first.t_s if first.t_s is not None else first.after_s or 0.0


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
    tempo += f", level: {music.level}" if music.level else ""
    tempo += f", offset_beats: {fmt(music.offset_beats)}" if music.offset_beats else ""
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
    if absolute < 1:
        reader.report(
            anchor.value,
            f"{ref.describe(absolute)} comes before beat 1, the motion's t=0 ({music.note}); "
            f"give {ref.describe(1)} or later, or an earlier start",
        )
        return None
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
