"""What conductor and performers say to each other: small frozen dataclasses, sent as JSON.

Times on the wire are wall-clock seconds (``time.time()``) on the sender's clock; the conductor
corrects a performer's by the offset it measured (:mod:`choreo.show.clock_offset`). An enum
field travels as its value and is an enum again once decoded.
"""

from __future__ import annotations

import base64
import dataclasses
import enum
import json
import types
import typing
from dataclasses import dataclass
from typing import Any, TypeVar

from choreo.errors import ChoreoError

M = TypeVar("M")


def encode(message: Any) -> bytes:
    return json.dumps(dataclasses.asdict(message), default=_enum_value).encode()


def _enum_value(value: object) -> object:
    if isinstance(value, enum.Enum):
        return value.value
    raise TypeError(f"{type(value).__name__} is not sent on the wire")


def decode(kind: type[M], payload: bytes) -> M:
    """A ``kind`` from its JSON; a ChoreoError saying what came instead (another version?)."""
    try:
        fields = json.loads(payload)
        hints = typing.get_type_hints(kind)
        return kind(**{k: _field(hints.get(k), v) for k, v in fields.items()})
    except (ValueError, TypeError) as error:
        raise ChoreoError(
            f"a {kind.__name__} message could not be read ({error}); are both sides the same "
            "choreo version?"
        ) from None


def _field(kind: object, value: object) -> object:
    if value is not None and typing.get_origin(kind) in (typing.Union, types.UnionType):
        kind = next(k for k in typing.get_args(kind) if k is not type(None))  # X | None
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        return kind(value)  # ValueError for a value this version does not know
    return tuple(value) if isinstance(value, list) else value


class PartOutcome(enum.Enum):
    """How a performer's part ended: as the player's ``Outcome`` (same values), or as only a
    show can end it."""

    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C / SIGTERM at the performer
    ABORTED = "aborted"  # a health check failed
    STOPPED = "stopped"  # the conductor's stop: Ctrl-C there, or another part aborted
    LOST = "lost"  # the conductor heard nothing more from the performer
    STAGED = "staged"  # a dry run: staged and preflighted, then released


class StopCause(enum.Enum):
    """Why a show stopped a performer's servos (the player's own stops, Ctrl-C at the performer
    or a failed health check, are told by its outcome)."""

    SILENCE = "silence"  # the conductor's heartbeat was silent past the bound
    CONDUCTOR_LOST = "conductor lost"  # its liveliness token vanished
    STOP_MESSAGE = "stop message"  # its signed stop: Ctrl-C there, or another part aborted


@dataclass(frozen=True)
class Announcement:
    """Who a performer is (the answer to ``<performer>/info``)."""

    name: str
    transport: str  # its bus: a port, or "emulated"
    robot: str  # "" until a part is staged
    state: str  # idle, staged, playing
    host: str = ""  # its computer's name, and its process there: two of one name are told apart
    pid: int = 0
    show_id: str = ""  # the show holding it ("" when free)


@dataclass(frozen=True)
class ClockReading:
    """A performer's wall clock when it answered a round trip."""

    time_s: float


@dataclass(frozen=True)
class StagedPart:
    """A part sent to a performer: the motion file and every file it uses, by relative path."""

    show_id: str
    ticket: str  # the conductor's secret for this show (choreo.show.ticket)
    motion: str  # relative path of the motion among ``files``
    robot_file: str  # relative path of its robot.yaml among ``files``
    files: tuple[tuple[str, str], ...]  # (relative path, base64 of the content)

    @staticmethod
    def of(
        show_id: str, ticket: str, motion: str, robot_file: str, contents: dict[str, bytes]
    ) -> StagedPart:
        files = tuple((path, base64.b64encode(data).decode()) for path, data in contents.items())
        return StagedPart(show_id, ticket, motion, robot_file, files)

    def contents(self) -> dict[str, bytes]:
        return {path: base64.b64decode(data) for path, data in self.files}


@dataclass(frozen=True)
class Readiness:
    """A performer's answer to a staged part: preflight passed, or every problem it found."""

    performer: str
    robot: str
    problems: tuple[str, ...]
    approach_s: float = 0.0  # the slow move into the first pose, before the motion's t=0
    duration_s: float = 0.0  # the motion itself
    unchecked: tuple[str, ...] = ()  # what preflight could not check through this transport

    @property
    def ok(self) -> bool:
        return not self.problems


@dataclass(frozen=True)
class Go:
    """Play the staged part: its motion's t=0 at ``start_s`` on the performer's wall clock."""

    show_id: str
    start_s: float
    ticket: str  # the one its part was staged with


@dataclass(frozen=True)
class Answer:
    """A performer's answer to a start: taken, or the problem that keeps it from playing."""

    performer: str
    problem: str = ""

    @property
    def ok(self) -> bool:
        return not self.problem


@dataclass(frozen=True)
class Stop:
    """Stop the servos now (Ctrl-C at the conductor, or another performer aborted); signed with
    the show's ticket over (show_id, "stop", reason)."""

    show_id: str
    reason: str
    signature: str


@dataclass(frozen=True)
class Beat:
    """The conductor is alive and in charge: sent every ``BEAT_PERIOD_S``; signed with the
    show's ticket over (show_id, "beat", seq), each ``seq`` higher than the last."""

    show_id: str
    seq: int
    signature: str


@dataclass(frozen=True)
class PartProgress:
    """How far a performer is into its part (a player's ``PlayProgress``, in the motion's
    time)."""

    performer: str
    time_s: float  # since the motion's t=0 (negative during the approach)
    duration_s: float


@dataclass(frozen=True)
class Finished:
    """How a performer's part ended; times on its own wall clock."""

    performer: str
    outcome: PartOutcome  # not LOST or STAGED: the conductor's own
    reason: str
    ticks_played: int
    ticks_total: int
    # read from the performer's clock when the START's bytes were written, on every transport
    approach_start_s: float | None  # the first START of the approach into the first pose
    first_start_s: float | None  # the first START of the part itself (its motion's t=0)
    stop_s: float | None  # its MOVE_STOP on the wire (emulated bus), if it stopped
    lateness_p99_ms: float
    first_start_late_ms: float | None = None  # written after it was due (negative: before)
    # read from its clock when its MOVE_STOP bytes were written (any transport), and why
    stop_written_s: float | None = None
    stop_cause: StopCause | None = None
