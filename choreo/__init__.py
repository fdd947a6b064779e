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

from .errors import (
    BusError,
    BusTimeoutError,
    ChoreoError,
    PlanningError,
    PlaybackAborted,
    PortError,
    PreviewError,
    ProtocolError,
    ServoFault,
    SourceError,
)

__version__ = "0.1.0"

# name -> the module that defines it (imported on first use, see __getattr__)
_LAZY = {
    "Robot": "robot",
    "Joint": "robot",
    "load_robot": "robot_file",
    "Motion": "motion",
    "Keyframe": "motion",
    "load_motion": "motion",
    "Trajectory": "planner",
    "plan_motion": "planner",
    "CompiledMotion": "pipeline",
    "compile_motion": "pipeline",
    "ServoBus": "bus",
    "RealClock": "clock",
    "VirtualClock": "clock",
    "Player": "player",
    "PlayOptions": "player",
    "PlayReport": "player",
    "ExitMode": "player",
    "preflight": "player",
    "prepare": "player",
    "simulate_motion": "preview",
}

__all__ = [
    "BusError",
    "BusTimeoutError",
    "ChoreoError",
    "PlanningError",
    "PlaybackAborted",
    "PortError",
    "PreviewError",
    "ProtocolError",
    "ServoFault",
    "SourceError",
    "__version__",
    "Robot",
    "Joint",
    "load_robot",
    "Motion",
    "Keyframe",
    "load_motion",
    "Trajectory",
    "plan_motion",
    "CompiledMotion",
    "compile_motion",
    "ServoBus",
    "RealClock",
    "VirtualClock",
    "Player",
    "PlayOptions",
    "PlayReport",
    "ExitMode",
    "preflight",
    "prepare",
    "simulate_motion",
]


def __getattr__(name: str) -> object:
    if name not in _LAZY:
        raise AttributeError(f"module 'choreo' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    globals()[name] = value  # found directly next time
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if TYPE_CHECKING:  # what type checkers and editors see; at run time, __getattr__ above
    from .bus import ServoBus
    from .clock import RealClock, VirtualClock
    from .motion import Keyframe, Motion, load_motion
    from .pipeline import CompiledMotion, compile_motion
    from .planner import Trajectory, plan_motion
    from .player import ExitMode, Player, PlayOptions, PlayReport, preflight, prepare
    from .preview import simulate_motion
    from .robot import Joint, Robot
    from .robot_file import load_robot
