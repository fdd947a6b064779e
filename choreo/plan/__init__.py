"""Planning: keyframes time-parameterized by Ruckig into smooth, jerk-limited, synchronized
trajectories, compiled into the servos' own linear moves (ticks).

- :mod:`~choreo.plan.planner`: :func:`plan_motion`, Ruckig's profiles between keyframes;
- :mod:`~choreo.plan.trajectory`: :class:`Trajectory`, the plan as polynomials, sampled;
- :mod:`~choreo.plan.ticks`: trajectories cut into ticks within a tolerance and the bus's bytes;
- :mod:`~choreo.plan.pipeline`: :class:`PlanOptions` (speed, stretch, tolerance) and
  :func:`compile_motion`, the plan and its ticks;
- :mod:`~choreo.plan.approach`: the slow move from wherever the servos stand to a pose;
- :mod:`~choreo.plan.performance`: :func:`prepare`, that approach from where the servos are, then
  the motion: what the player plays and the preview simulates;
- :mod:`~choreo.plan.plot`: the plan as a picture.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from choreo.plan.pipeline import CompiledMotion, PlanOptions, compile_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import Tick, TickPlan
from choreo.plan.trajectory import PlanResult, Trajectory

# The performance (what play and preview start from) is imported on first use: `choreo plan`
# does without it.
_MODULE_OF = {"Performance": "choreo.plan.performance", "prepare": "choreo.plan.performance"}
__all__ = [
    "CompiledMotion",
    "Performance",
    "PlanOptions",
    "PlanResult",
    "Tick",
    "TickPlan",
    "Trajectory",
    "compile_motion",
    "plan_motion",
    "prepare",
]


def __getattr__(name: str) -> object:
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'choreo.plan' has no attribute {name!r}")
    return getattr(importlib.import_module(_MODULE_OF[name]), name)


if TYPE_CHECKING:
    from choreo.plan.performance import Performance, prepare
