"""choreo: jerk-limited, synchronized motion for Hiwonder/LewanSoul serial bus servos.

The public API, importable from here: load a robot and a motion, plan and compile it, then play
it on a bus (a serial port, or the built-in emulator's ``sim://`` URLs)::

    from choreo import ServoBus, compile_motion, load_motion

Everything but the errors is imported on first use, so that ``import choreo`` (and every command
that needs only the bus) stays fast and never imports the planner's or the preview's libraries.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from choreo import errors
from choreo.errors import (  # imported at once: light, and what every program catches
    BusError,
    BusTimeoutError,
    ChoreoError,
    NoAudioOutput,
    OptionError,
    PlanningError,
    PlaybackAborted,
    PortError,
    PreviewError,
    ProtocolError,
    ServoFault,
    SourceError,
    UnsupportedByTransport,
)

__version__ = "0.1.0"

# The public API: each name, by the module that defines it; imported on first use (__getattr__).
PUBLIC = {
    "choreo.robot.types": ("Robot", "Joint"),
    "choreo.robot.robot_file": ("load_robot",),
    "choreo.motion.motion_file": ("Motion", "Keyframe", "load_motion"),
    "choreo.plan.planner": ("plan_motion",),
    "choreo.plan.trajectory": ("Trajectory", "PlanResult"),
    "choreo.plan.pipeline": ("CompiledMotion", "PlanOptions", "compile_motion"),
    "choreo.plan.performance": ("Performance", "prepare"),
    "choreo.plan.report": ("plan_report",),
    "choreo.bus.servo_bus": ("ServoBus",),
    "choreo.core.clock": ("RealClock", "VirtualClock"),
    "choreo.play.play_options": ("PlayOptions", "ExitMode"),
    "choreo.play.preflight": ("preflight",),
    "choreo.play.player": ("Player",),
    "choreo.play.play_motion": ("play_motion",),
    "choreo.play.report": ("PlayReport", "StreamReport", "Outcome", "report_document"),
    "choreo.preview.pipeline": ("simulate_motion",),
    "choreo.preview.simulated": ("SimulatedMotion",),
    "choreo.preview.checks": ("run_checks",),
    "choreo.preview.report": ("preview_report",),
    "choreo.music.decode": ("Audio", "decode_song"),
    "choreo.music.beats": ("BeatAnalysis", "detect_beats"),
    "choreo.music.report": ("beats_report",),
}
_MODULE_OF = {name: module for module, names in PUBLIC.items() for name in names}
# every error a user can meet (UsageError is the command line's own)
ERRORS = tuple(
    name
    for name, value in vars(errors).items()
    if isinstance(value, type) and issubclass(value, ChoreoError) and name != "UsageError"
)
__all__ = ["__version__", *ERRORS, *_MODULE_OF]


def __getattr__(name: str) -> object:
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'choreo' has no attribute {name!r}")
    value = getattr(importlib.import_module(_MODULE_OF[name]), name)
    globals()[name] = value  # found directly next time
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_MODULE_OF))


# What type checkers and editors see (at run time, __getattr__ above); test_package checks that
# these imports and PUBLIC name the same things.
if TYPE_CHECKING:
    from choreo.bus.servo_bus import ServoBus
    from choreo.core.clock import RealClock, VirtualClock
    from choreo.motion.motion_file import Keyframe, Motion, load_motion
    from choreo.music.beats import BeatAnalysis, detect_beats
    from choreo.music.decode import Audio, decode_song
    from choreo.music.report import beats_report
    from choreo.plan.performance import Performance, prepare
    from choreo.plan.pipeline import CompiledMotion, PlanOptions, compile_motion
    from choreo.plan.planner import plan_motion
    from choreo.plan.report import plan_report
    from choreo.plan.trajectory import PlanResult, Trajectory
    from choreo.play.play_motion import play_motion
    from choreo.play.play_options import ExitMode, PlayOptions
    from choreo.play.player import Player
    from choreo.play.preflight import preflight
    from choreo.play.report import Outcome, PlayReport, StreamReport, report_document
    from choreo.preview.checks import run_checks
    from choreo.preview.pipeline import simulate_motion
    from choreo.preview.report import preview_report
    from choreo.preview.simulated import SimulatedMotion
    from choreo.robot.robot_file import load_robot
    from choreo.robot.types import Joint, Robot
