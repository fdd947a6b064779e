"""The machine-readable report of one play (``choreo play --report FILE.json``).

One JSON document per play, written atomically: what happened (outcome, ticks, re-targets), how
well it was timed (START lateness, first-to-last start skew), what it cost the bus (bytes, bus
use, missed health reads), what the health reads saw on each servo, and, on the emulator, how far
the servos' real paths strayed from the smooth plan.
"""

from __future__ import annotations

import json
import urllib.parse
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from choreo.core.arguments import check_type
from choreo.core.atomic import write_text_atomically
from choreo.play.player import PlayReport

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


def report_document(report: PlayReport) -> dict[str, Any]:
    """The JSON document of a :func:`~choreo.play.play_motion.play_motion` report. The measured
    start skew and the path errors come from an emulator's wire log (None on real servos: the
    skew is then the transport's own)."""
    check_type("report", report, PlayReport, "a PlayReport (from play_motion)")
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
        "servos": [
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
            for i, h in enumerate(report.health)
        ],
    }


def write_report(path: Path, document: dict[str, Any]) -> None:
    """Write atomically: a reader sees the previous file or the whole new one."""
    write_text_atomically(path, json.dumps(document, indent=2) + "\n")
