"""A recording taught by hand, kept safe as it grows: every capture is appended at once to a
journal (``OUT.yaml.journal``: a JSON header line, then one JSON line per capture or undo, each
flushed and fsync'ed), so a crash, a kill or an unplugged cable loses nothing and
:meth:`Recording.resume` continues where it stopped. At the end the journal is turned into the
motion file (written atomically: a temporary file, then ``os.replace``) and removed.

A stream of samples is reduced to keyframes by Douglas-Peucker over time: the kept samples,
joined by straight lines in time, stay within a tolerance of every sample on every joint. The
live side, the servos and what the user types, is :mod:`choreo.play.recorder`.
"""

from __future__ import annotations

import itertools
import json
import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import BinaryIO

import numpy as np

from choreo.core.atomic import check_writable, fsync_directory, write_text_atomically
from choreo.core.yaml_source import SourceLocation
from choreo.errors import ChoreoError
from choreo.motion.motion_file import Keyframe
from choreo.motion.writer import motion_text, robot_reference
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot

log = logging.getLogger(__name__)


JOURNAL_FORMAT = "choreo-record-journal"
JOURNAL_VERSION = 1
JOURNAL_SUFFIX = ".journal"
ANGLE_DECIMALS = 2  # a position unit is 0.24°, so 0.01° keeps every reading exact
TIME_DECIMALS = 2  # seconds in the motion file (the journal keeps full precision)


@dataclass(frozen=True)
class Capture:
    angles_deg: tuple[float, ...]  # every joint, robot joint order, 0.01° resolution
    after_s: float | None  # since the previous capture; None for the first of a recording
    stream: int | None = None  # the stream it was sampled in; None: captured on its own


# --- the journal ---------------------------------------------------------------------------------
def journal_path(motion_path: Path) -> Path:
    return motion_path.with_name(motion_path.name + JOURNAL_SUFFIX)


@dataclass(frozen=True)
class JournalContents:
    robot_path: Path
    joint_names: tuple[str, ...]
    captures: tuple[Capture, ...]  # undos applied
    good_bytes: int  # the length up to the last complete line (a torn last line is dropped)


def read_journal(path: Path) -> JournalContents:
    """Replay a journal; ``ChoreoError`` naming the line if it is damaged before its last line."""
    data = path.read_bytes()
    *lines, torn = data.split(b"\n")
    if torn:
        log.warning(
            "%s: dropping an incomplete last line (written when the recorder stopped)", path
        )
    if not lines:
        raise ChoreoError(f"{path}: empty journal: delete it and record again")
    header = _journal_line(path, 1, lines[0])
    if (
        header.get("format") != JOURNAL_FORMAT
        or header.get("version") != JOURNAL_VERSION
        or not isinstance(header.get("robot"), str)
        or not isinstance(header.get("joints"), list)
    ):
        raise ChoreoError(f"{path}:1: not a {JOURNAL_FORMAT} version {JOURNAL_VERSION} file")
    joint_names = tuple(header["joints"])
    captures: list[Capture] = []
    for number, line in enumerate(lines[1:], start=2):
        record = _journal_line(path, number, line)
        try:
            _replay(record, captures, joint_names)
        except (KeyError, TypeError, ValueError) as error:
            raise ChoreoError(
                f"{path}:{number}: damaged journal line ({error}): {line[:80]!r}"
            ) from None
    return JournalContents(
        Path(header["robot"]), joint_names, tuple(captures), len(data) - len(torn)
    )


def _journal_line(path: Path, number: int, line: bytes) -> dict:
    try:
        record = json.loads(line)
    except ValueError:
        record = None
    if not isinstance(record, dict):
        raise ChoreoError(
            f"{path}:{number}: damaged journal line, not a JSON object: {line[:80]!r}"
        )
    return record


def _replay(record: dict, captures: list[Capture], joint_names: tuple[str, ...]) -> None:
    if "undo" in record:
        if record["undo"] != len(captures):
            raise ValueError(f"undo of capture {record['undo']}, but the last is {len(captures)}")
        captures.pop()
        return
    if record["capture"] != len(captures) + 1:
        raise ValueError(f"capture {record['capture']} follows capture {len(captures)}")
    angles = record["angles_deg"]
    captures.append(
        Capture(
            tuple(float(angles[name]) for name in joint_names), record["after_s"], record["stream"]
        )
    )


class Journal:
    """An append-only journal file; every line is on disk before ``append`` returns."""

    def __init__(self, path: Path, file: BinaryIO):
        self.path = path
        self._file = file

    @classmethod
    def create(cls, path: Path, robot: Robot) -> Journal:
        try:
            file = open(path, "xb")
        except FileExistsError:
            raise ChoreoError(f"{path} already exists") from None
        except OSError as error:
            raise ChoreoError(f"cannot create {path}: {error.strerror}") from error
        journal = cls(path, file)
        journal.append(
            dict(
                format=JOURNAL_FORMAT,
                version=JOURNAL_VERSION,
                robot=str(robot.path.resolve()),
                joints=list(robot.joint_names),
            )
        )
        fsync_directory(path.parent)  # the new file's name is durable too
        return journal

    @classmethod
    def reopen(cls, path: Path, good_bytes: int) -> Journal:
        file = open(path, "r+b")
        file.truncate(good_bytes)  # drop a torn last line before appending after it
        file.seek(good_bytes)
        return cls(path, file)

    def append(self, record: dict) -> None:
        self._file.write(json.dumps(record).encode("ascii") + b"\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        self._file.close()


# --- the recording: captures, journaled -----------------------------------------------------------
@dataclass(frozen=True)
class SavedMotion:
    path: Path
    captures: int
    keyframes: int


class Recording:
    """The captures of one recording into ``motion_path``, journaled as they come."""

    def __init__(
        self, motion_path: Path, robot: Robot, journal: Journal, captures: Sequence[Capture] = ()
    ):
        self.motion_path = motion_path
        self.robot = robot
        self.journal = journal
        self._captures = list(captures)

    @classmethod
    def start(cls, motion_path: Path, robot: Robot, *, overwrite: bool = False) -> Recording:
        """A new recording; refuses to replace a journal (resume it) or, unless ``overwrite``,
        an existing motion file."""
        motion_path = Path(motion_path)
        path = journal_path(motion_path)
        if path.exists():
            count = len(read_journal(path).captures)
            raise ChoreoError.naming(
                "Recording.resume",
                f"{path} holds {count} capture(s) of an unfinished recording: continue it "
                "({option}), or delete it to start over",
            )
        check_writable(motion_path, overwrite=overwrite)  # before any servo goes limp
        return cls(motion_path, robot, Journal.create(path, robot))

    @classmethod
    def resume(cls, motion_path: Path, robot: Robot | None = None) -> Recording:
        """Continue an unfinished recording from its journal (its robot, unless given)."""
        motion_path = Path(motion_path)
        path = journal_path(motion_path)
        if not path.exists():
            raise ChoreoError(
                f"nothing to resume: {path} does not exist (a recording that was "
                "saved removes its journal)"
            )
        contents = read_journal(path)
        if robot is None:
            robot = load_robot(contents.robot_path)
            if robot.joint_names != contents.joint_names:  # robot.yaml changed since
                raise ChoreoError(
                    f"{path} was recorded with the joints {', '.join(contents.joint_names)}, but "
                    f"{robot.path} now has {', '.join(robot.joint_names)}: its captures can't be "
                    "matched to the joints; restore the robot file, or delete the journal"
                )
        elif (
            robot.path.resolve() != contents.robot_path or robot.joint_names != contents.joint_names
        ):
            raise ChoreoError(
                f"{path} was recorded with the robot {contents.robot_path} (joints "
                f"{', '.join(contents.joint_names)}), not {robot.path}: resume "
                "with that robot, or delete the journal"
            )
        return cls(motion_path, robot, Journal.reopen(path, contents.good_bytes), contents.captures)

    @property
    def captures(self) -> tuple[Capture, ...]:
        return tuple(self._captures)

    def next_stream(self) -> int:
        return 1 + max((c.stream for c in self._captures if c.stream is not None), default=0)

    def add(self, capture: Capture) -> int:
        """Journal a capture (on disk when this returns); its number."""
        number = len(self._captures) + 1
        angles = dict(zip(self.robot.joint_names, capture.angles_deg))
        self.journal.append(
            dict(capture=number, after_s=capture.after_s, stream=capture.stream, angles_deg=angles)
        )
        self._captures.append(capture)
        return number

    def undo(self) -> int | None:
        """Remove the last capture; its number, or None if there is none."""
        if not self._captures:
            return None
        number = len(self._captures)
        self.journal.append(dict(undo=number))
        self._captures.pop()
        return number

    def save(self, tolerance_deg: float = 1.0) -> SavedMotion | None:
        """Write the motion file (streams reduced within ``tolerance_deg``) and remove the
        journal; None, and no file, if nothing was captured."""
        captures = read_journal(self.journal.path).captures  # the journal is the source of truth
        if not captures:
            return None
        keyframes = reduce_captures(captures, tolerance_deg)
        text = motion_text(
            self.robot,
            as_keyframes(keyframes, self.motion_path),
            robot_ref=robot_reference(self.robot, self.motion_path),
            description=f"recorded by hand on {self.robot.name}: {len(captures)} capture(s)",
        )
        write_text_atomically(self.motion_path, text)
        self.journal.close()
        self.journal.path.unlink()
        return SavedMotion(self.motion_path, len(captures), len(keyframes))

    def close(self) -> None:
        """Close the journal; remove it if it holds no capture (nothing to resume)."""
        self.journal.close()
        path = self.journal.path
        if path.exists() and not self._captures and not read_journal(path).captures:
            path.unlink()


# --- streams to keyframes -------------------------------------------------------------------------
def douglas_peucker(
    times_s: Sequence[float] | np.ndarray,
    angles_deg: Sequence[Sequence[float]],
    tolerance_deg: float,
) -> list[int]:
    """Indices of the samples to keep (always the first and last) so that straight lines in time
    between kept samples pass within ``tolerance_deg`` of every sample, on every joint."""
    times = np.asarray(times_s, dtype=float)
    angles = np.asarray(angles_deg, dtype=float).reshape(len(times), -1)
    count = len(times)
    if count <= 2:
        return list(range(count))
    keep = np.zeros(count, dtype=bool)
    keep[[0, -1]] = True
    spans = [(0, count - 1)]
    while spans:
        first, last = spans.pop()
        if last - first < 2:
            continue
        duration = times[last] - times[first]
        inner = times[first + 1 : last] - times[first]
        fraction = inner / duration if duration > 0 else np.zeros_like(inner)
        line = angles[first] + np.outer(fraction, angles[last] - angles[first])
        errors = np.abs(angles[first + 1 : last] - line).max(axis=1)
        worst = int(np.argmax(errors))
        if errors[worst] > tolerance_deg:
            middle = first + 1 + worst
            keep[middle] = True
            spans += [(first, middle), (middle, last)]
    return [int(i) for i in np.flatnonzero(keep)]


def reduce_captures(captures: Sequence[Capture], tolerance_deg: float) -> list[Capture]:
    """Captures as keyframes: single captures as they are, each stream reduced by
    Douglas-Peucker; a kept sample's ``after_s`` is the time since the sample kept before it."""
    if not tolerance_deg > 0:
        raise ValueError(f"tolerance_deg must be > 0, got {tolerance_deg}")
    keyframes: list[Capture] = []
    for stream, members in itertools.groupby(captures, key=lambda c: c.stream):
        group = list(members)
        if stream is None:
            keyframes += group
            continue
        # Rounded arrival times, so rounding the delays does not add up along the stream.
        times_s = np.round(np.cumsum([0.0] + [c.after_s for c in group[1:]]), TIME_DECIMALS)
        kept = douglas_peucker(times_s, [c.angles_deg for c in group], tolerance_deg)
        keyframes.append(group[0])
        for before, index in zip(kept, kept[1:]):
            after_s = round(float(times_s[index] - times_s[before]), TIME_DECIMALS)
            keyframes.append(replace(group[index], after_s=after_s))
    return keyframes


# --- the motion file ------------------------------------------------------------------------------
def as_keyframes(captures: Sequence[Capture], motion_path: Path) -> list[Keyframe]:
    """Captures as the motion file's keyframes (they have no source line yet: the file's top)."""
    where = SourceLocation(motion_path, 1, 1)
    return [Keyframe(c.angles_deg, where, after_s=c.after_s) for c in captures]
