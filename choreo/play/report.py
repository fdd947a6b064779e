"""What a play tells: its progress while it runs (``PlayProgress``), and after it the report.

``Player.play`` reports what it measured on the stream of ticks (``StreamReport``): the
outcome, ticks, re-targets, START lateness, bytes, and what the health reads saw on each servo.
``play_motion``'s report (``PlayReport``) adds what was played where and, on the emulator, how
far the servos' real paths strayed from the smooth plan and how far apart a tick's servos
started. ``report_document`` gives that as one JSON document (``choreo play --report
FILE.json``), written atomically.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import urllib.parse
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from choreo.bus.protocol import BYTE_TIME_S
from choreo.core.arguments import check_type
from choreo.core.atomic import write_text_atomically
from choreo.play.health import ServoHealth
from choreo.play.realtime import NOT_ASKED, Scheduling


class Outcome(enum.Enum):
    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C / SIGTERM
    ABORTED = "aborted"  # a health check failed


@dataclass(frozen=True)
class PlayProgress:
    """Where a play is, told after each START (``on_progress``)."""

    time_s: float  # since the first START
    duration_s: float
    tick: int  # ticks started so far
    ticks: int
    bus_use: float
    stage: str = ""  # what is being played, in words (play_motion: approach, keyframe 3/12)


@dataclass(frozen=True)
class StartTime:
    """One START on the player's clock: when its moves were to begin, when its bytes were due to
    be written (the deadline less their time on the wire), and when writing them returned
    (measured, whatever the transport)."""

    deadline_s: float
    write_at_s: float
    written_s: float

    @property
    def late_ms(self) -> float:
        return (self.written_s - self.write_at_s) * 1000


@dataclass(frozen=True)
class StreamReport:
    """What the player measured playing a list of ticks (``Player.play``)."""

    outcome: Outcome
    reason: str
    ticks_played: int
    ticks_total: int
    retargeted: int
    lateness_ms: tuple[float, ...]  # per START, against its deadline
    bytes_sent: int
    planned_s: float
    elapsed_s: float
    health: tuple[ServoHealth, ...]
    start_time_s: float  # clock time of the first START's deadline
    transport: str = "raw LX bus"
    start_skew_ms: float = 0.0  # first-to-last start of a tick's moves (a board forwarding them)
    scheduling: Scheduling = NOT_ASKED  # the priority the play ran with
    start_times: tuple[StartTime, ...] = ()  # per START

    @property
    def bus_use(self) -> float:
        return self.bytes_sent * BYTE_TIME_S / self.elapsed_s if self.elapsed_s > 0 else 0.0

    def lateness_percentile_ms(self, q: float) -> float:
        return float(np.percentile(self.lateness_ms, q)) if self.lateness_ms else 0.0

    @property
    def missed_reads(self) -> int:
        """Health reads that went unanswered or came back garbled, over every servo."""
        return sum(h.missed_total for h in self.health)

    @property
    def end_error_ms(self) -> float:
        return (self.elapsed_s - self.planned_s) * 1000


@dataclass(frozen=True)
class PlayReport(StreamReport):
    """``play_motion``'s report: the stream's, and what was played where and, on an emulator,
    what its wire shows."""

    motion: str = ""
    robot: str = ""
    port: str = ""
    emulated: bool = False
    measured_start_skew_ms: float | None = None
    path_errors_deg: tuple[float, ...] | None = None  # per joint, against the smooth plan
    exit_move: StreamReport | None = None  # the move to the exit pose, if one was made

    @classmethod
    def of(cls, stream: StreamReport, **played: Any) -> PlayReport:
        """``stream``'s report with ``played`` (this class's own fields) added."""
        measured = {f.name: getattr(stream, f.name) for f in dataclasses.fields(StreamReport)}
        return cls(**measured, **played)


REPORT_FORMAT = "choreo-play-report"
REPORT_VERSION = 1


@dataclass(frozen=True)
class Transport:
    """How the host reached the servos.

    ``kind`` is the port's scheme (``serial`` for a plain device path such as /dev/ttyUSB0,
    ``sim`` for the emulator); transports with their own scheme report it the same way.
    ``start_skew_ms`` is the first-to-last start skew that way of starting a tick costs where it
    cannot be measured: 0 for a broadcast MOVE_START; a board that forwards a tick one servo at a
    time sets its own figure.
    """

    kind: str
    port: str
    emulated: bool
    start_skew_ms: float = 0.0
    name: str = "raw LX bus"  # what carries the commands: the raw bus or a controller board


def transport_of(port_name: str, report: PlayReport | None = None) -> Transport:
    """The transport of ``port_name``; ``report`` adds the player's name for it and the start
    skew its way of starting a tick costs."""
    scheme = urllib.parse.urlsplit(port_name).scheme.lower() if "://" in port_name else ""
    transport = Transport(kind=scheme or "serial", port=port_name, emulated=scheme == "sim")
    if report is None:
        return transport
    return replace(transport, name=report.transport, start_skew_ms=report.start_skew_ms)


def report_document(report: StreamReport) -> dict[str, Any]:
    """The JSON document of a :func:`~choreo.play.play_motion.play_motion` report (or of a
    ``Player.play`` report, which says nothing of what was played where). The measured start
    skew and the path errors come from an emulator's wire log (None on real servos: the skew is
    then the transport's own)."""
    check_type("report", report, StreamReport, "a PlayReport (from play_motion)")
    if not isinstance(report, PlayReport):
        report = PlayReport.of(report)
    skew_ms = report.measured_start_skew_ms
    path_errors_deg = report.path_errors_deg
    transport = transport_of(report.port, report)
    return {
        "format": REPORT_FORMAT,
        "version": REPORT_VERSION,
        "motion": report.motion,
        "robot": report.robot,
        "outcome": report.outcome.value,
        "reason": report.reason,
        "transport": {
            "kind": transport.kind,
            "name": transport.name,
            "port": transport.port,
            "emulated": transport.emulated,
        },
        "scheduling": {
            "policy": report.scheduling.policy,
            "priority": report.scheduling.priority,
            "memory_locked": report.scheduling.memory_locked,
            "realtime_asked": report.scheduling.asked,
        },
        "ticks": {
            "played": report.ticks_played,
            "total": report.ticks_total,
            "retargeted": report.retargeted,
        },
        "start_lateness_ms": {
            "p50": report.lateness_percentile_ms(50),
            "p99": report.lateness_percentile_ms(99),
            "max": max(report.lateness_ms, default=0.0),
            "starts": len(report.lateness_ms),
        },
        "start_skew_ms": {
            "max": skew_ms if skew_ms is not None else transport.start_skew_ms,
            "measured": skew_ms is not None,
        },
        "timing": {
            "planned_s": report.planned_s,
            "elapsed_s": report.elapsed_s,
            "end_error_ms": report.end_error_ms,
        },
        "bus": {
            "bytes_sent": report.bytes_sent,
            "use_fraction": report.bus_use,
            "missed_reads": report.missed_reads,
        },
        "path_error_deg_max": max(path_errors_deg) if path_errors_deg else None,
        "servos": _servo_rows(report.health, path_errors_deg),
    }


def _servo_rows(
    health: tuple[ServoHealth, ...], path_errors_deg: tuple[float, ...] | None
) -> list[dict[str, Any]]:
    return [
        {
            "joint": h.joint,
            "id": h.servo_id,
            "temp_c": {"min": h.temp_c_min, "max": h.temp_c_max},
            "vin_mv": {"min": h.vin_mv_min, "max": h.vin_mv_max},
            "position_error_deg_max": h.position_error_deg_max,
            "path_error_deg": path_errors_deg[i] if path_errors_deg else None,
            "reads": h.reads,
            "missed_reads": h.missed_total,
        }
        for i, h in enumerate(health)
    ]


def write_report(path: Path, document: dict[str, Any]) -> None:
    """Write atomically: a reader sees the previous file or the whole new one."""
    write_text_atomically(path, json.dumps(document, indent=2) + "\n")
