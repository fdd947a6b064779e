"""Show files: ``shows/*.yaml`` -> a validated ``Show`` (who dances what, with which song).

Only the file itself is read here; the performers' motions are loaded by whoever needs them (the
conductor stages them, ``choreo validate`` plans them). The keys come from
``choreo/schema/show.schema.json``.
"""

from __future__ import annotations

import dataclasses
import enum
from dataclasses import dataclass
from pathlib import Path

import yaml

from choreo.core.file_shape import choices, mapping_shape
from choreo.core.yaml_source import Entry, Node, Problems, Reader, SourceLocation, parse_yaml_file
from choreo.errors import SourceError
from choreo.music.decode import check_song_path
from choreo.show.names import NAME_RULE, is_name

SHOW = mapping_shape("show")
MUSIC = mapping_shape("show", "#/properties/music")
PERFORMER = mapping_shape("show", "#/$defs/performer")
CUE = mapping_shape("show", "#/$defs/cue")
DEFAULT_MAX_CLOCK_OFFSET_MS = 2.0
MAX_OFFSET_S = 3600.0  # a part starting later than this after the show's instant is a typo


class OnAbort(enum.Enum):
    STOP = "stop"  # a performer aborts or is lost: stop every other one
    CONTINUE = "continue"  # let the others finish


@dataclass(frozen=True)
class ShowMusic:
    song: Path
    start_s: float  # song time at the show's start instant
    bpm: float | None


@dataclass(frozen=True)
class Part:
    """One performer's part: its name, its motion file and when it starts."""

    performer: str
    motion: Path
    offset_s: float  # after the show's start instant
    where: SourceLocation


@dataclass(frozen=True)
class Cue:
    """Parts started together on one GO, after the cue before it has ended."""

    number: int  # from 1
    name: str
    parts: tuple[Part, ...]


@dataclass(frozen=True)
class Show:
    name: str
    path: Path
    parts: tuple[Part, ...]  # with cues: every cue's parts, in order
    music: ShowMusic | None = None
    on_abort: OnAbort = OnAbort.STOP
    max_clock_offset_s: float = DEFAULT_MAX_CLOCK_OFFSET_MS / 1000
    cues: tuple[Cue, ...] = ()

    def in_cues(self) -> list[Show]:
        """The show as the conductor plays it: one show per cue, in order (the song with the
        first); a show without cues is its one cue."""
        if not self.cues:
            return [self]
        return [
            dataclasses.replace(
                self,
                name=f"{self.name}, cue {cue.number} ({cue.name})",
                parts=cue.parts,
                music=self.music if cue.number == 1 else None,
                cues=(),
            )
            for cue in self.cues
        ]


def is_show_file(path: Path) -> bool:
    """Whether ``path`` holds a show (a mapping with ``performers``) rather than a motion."""
    try:
        root = parse_yaml_file(path)
    except SourceError:
        return False  # reported when it is read as a motion
    return is_show_yaml(root)


def is_show_yaml(root: Node | None) -> bool:
    """Whether a file's parsed YAML is a show's (a mapping with ``performers`` or ``cues``)."""
    return isinstance(root, yaml.MappingNode) and any(
        k.value in ("performers", "cues") for k, _ in root.value
    )


def load_show(path: str | Path) -> Show:
    """Read a show file; every problem in one ``SourceError`` of ``path:line:col:`` lines."""
    path = Path(path)
    problems = Problems()
    reader = Reader(path, problems)
    root = parse_yaml_file(path)
    show = _read_show(reader, root) if root is not None else None
    if root is None:
        problems.add(SourceLocation(path, 1, 1), "the show file is empty; it needs performers")
    if show is None or problems:
        raise SourceError(problems.messages)
    return show


def _read_show(reader: Reader, root: Node) -> Show | None:
    fields = reader.fields(root, "the show", SHOW.keys, SHOW.required)
    if fields is None:
        return None
    if ("performers" in fields) == ("cues" in fields):
        reader.report(root, "give either performers (played together) or cues (played one "
                      "after another, each with its performers)")  # fmt: skip
        return None
    music = _read_music(reader, fields["music"]) if "music" in fields else None
    on_abort = (
        reader.choice(
            fields["on_abort"].value, "on_abort", choices("show", "#/properties/on_abort")
        )
        if "on_abort" in fields
        else None
    )
    max_offset_ms = (
        reader.number(fields["max_clock_offset_ms"].value, "max_clock_offset_ms", low=0,
                      low_open=True, high=1000)
        if "max_clock_offset_ms" in fields
        else DEFAULT_MAX_CLOCK_OFFSET_MS
    )  # fmt: skip
    name = reader.string(fields["name"].value, "name") if "name" in fields else reader.path.stem
    cues = (
        _read_cues(reader, fields["cues"], music)
        if "cues" in fields
        else (None if (p := _read_parts(reader, fields["performers"], music)) is None
              else (Cue(1, "", p),))
    )  # fmt: skip
    if cues is None or max_offset_ms is None or name is None:
        return None
    return Show(
        name,
        reader.path,
        tuple(part for cue in cues for part in cue.parts),
        music,
        OnAbort(on_abort) if on_abort else OnAbort.STOP,
        max_offset_ms / 1000,
        cues if "cues" in fields else (),
    )


def _read_cues(reader: Reader, entry: Entry, music: ShowMusic | None) -> tuple[Cue, ...] | None:
    items = reader.sequence(entry.value, "cues")
    if items is None:
        return None
    if not items:
        reader.report(entry.value, "cues is empty; give at least one")
        return None
    cues = []
    for number, item in enumerate(items, 1):
        fields = reader.fields(item, f"cue {number}", CUE.keys, CUE.required)
        if fields is None or "performers" not in fields:
            continue
        name = reader.string(fields["name"].value, "name") if "name" in fields else f"cue {number}"
        parts = _read_parts(reader, fields["performers"], music)
        if parts is not None and name is not None:
            cues.append(Cue(number, name, parts))
    return tuple(cues) if len(cues) == len(items) else None


def _read_music(reader: Reader, entry: Entry) -> ShowMusic | None:
    fields = reader.fields(entry.value, "music", MUSIC.keys, MUSIC.required)
    if fields is None or "song" not in fields:
        return None
    relative = reader.string(fields["song"].value, "song")
    song = reader.path.parent / relative if relative else None
    problem = check_song_path(song) if song else None
    if problem:
        reader.report(fields["song"].value, f"song: {problem} (relative to this file's folder)")
    start = reader.number(fields["start"].value, "start", low=0) if "start" in fields else 0.0
    bpm = (
        reader.number(fields["bpm"].value, "bpm", low=0, low_open=True, high=1000)
        if "bpm" in fields
        else None
    )
    if song is None or problem or start is None or ("bpm" in fields and bpm is None):
        return None
    return ShowMusic(song, start, bpm)


def _read_parts(reader: Reader, entry: Entry, music: ShowMusic | None) -> tuple[Part, ...] | None:
    items = reader.sequence(entry.value, "performers")
    if items is None:
        return None
    if not items:
        reader.report(entry.value, "performers is empty; name at least one")
        return None
    parts: list[Part] = []
    seen: dict[str, SourceLocation] = {}
    for item in items:
        part = _read_part(reader, item, music)
        if part is None:
            continue
        if part.performer in seen:
            reader.report(
                item,
                f"performer {part.performer!r} is named twice (first at line "
                f"{seen[part.performer].line}); each performer dances one part",
            )
            continue
        seen[part.performer] = part.where
        parts.append(part)
    return tuple(parts) if len(parts) == len(items) else None


def _read_part(reader: Reader, item: Node, music: ShowMusic | None) -> Part | None:
    fields = reader.fields(item, "a performer", PERFORMER.keys, PERFORMER.required)
    if fields is None or not {"name", "motion"} <= fields.keys():
        return None
    name = reader.string(fields["name"].value, "name")
    if name is not None and not is_name(name):
        reader.report(fields["name"].value, f"performer name {name!r} may only have {NAME_RULE}")
        name = None
    relative = reader.string(fields["motion"].value, "motion")
    motion = reader.path.parent / relative if relative else None
    if motion is not None and not motion.is_file():
        reader.report(
            fields["motion"].value,
            f"motion: {motion} does not exist (paths are relative to this file's folder)",
        )
        motion = None
    elif motion is not None and is_show_file(motion):
        reader.report(
            fields["motion"].value,
            f"motion: {motion} is a show file, not a motion; a performer dances a motion file",
        )
        motion = None
    offset_s = _read_offset(reader, item, fields, music)
    if name is None or motion is None or offset_s is None:
        return None
    return Part(name, motion, offset_s, reader.where(item))


def _read_offset(
    reader: Reader, item: Node, fields: dict[str, Entry], music: ShowMusic | None
) -> float | None:
    if "offset_s" in fields and "offset_beats" in fields:
        reader.report(item, "give at most one of offset_s and offset_beats")
        return None
    if "offset_s" in fields:
        return reader.number(fields["offset_s"].value, "offset_s", low=0, high=MAX_OFFSET_S)
    if "offset_beats" not in fields:
        return 0.0
    beats = reader.number(fields["offset_beats"].value, "offset_beats", low=0)
    if beats is not None and (music is None or music.bpm is None):
        reader.report(
            fields["offset_beats"].key_node,
            "offset_beats needs the show's tempo: give music: {song: ..., bpm: ...}, "
            "or write the offset in seconds (offset_s)",
        )
        return None
    if beats is None or music is None or music.bpm is None:
        return None
    offset_s = beats * 60 / music.bpm
    if offset_s > MAX_OFFSET_S:  # inf too, from a huge number of beats
        reader.report(
            fields["offset_beats"].value,
            f"offset_beats {beats:g} at {music.bpm:g} BPM starts the part {offset_s:g} s after "
            f"the show's instant; the most is {MAX_OFFSET_S:g} s",
        )
        return None
    return offset_s
