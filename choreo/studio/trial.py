"""A motion file as an edit would write it, loaded and planned beside the real one before
anything is written: the file itself is never touched by a check."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from choreo.errors import ChoreoError, PlanningError, SourceError
from choreo.motion.motion_file import Motion, load_motion
from choreo.plan.planner import plan_motion
from choreo.studio.session import Plan, make_plan

T = TypeVar("T")


def check_loads(path: Path, text: str) -> Motion:
    """The motion ``text`` written to ``path`` would be; ``SourceError`` (naming ``path``) if
    it would not load."""
    return _trial(path, text, load_motion)


def check_plans(path: Path, text: str) -> Plan:
    """The plan the studio would show for ``text`` written to ``path``; ``SourceError`` or
    ``PlanningError`` (naming ``path``) if it would not load or plan."""
    return _trial(path, text, lambda trial: make_plan(load_motion(trial)))


def plans(path: Path, text: str) -> bool:
    """Whether ``text`` written to ``path`` would load and plan: the planner alone, without
    the ticks and poses the page shows (a fifth of ``check_plans``' time on a long motion)."""
    try:
        _trial(path, text, lambda trial: plan_motion(load_motion(trial)))
    except ChoreoError:
        return False
    return True


def _trial(path: Path, text: str, make: Callable[[Path], T]) -> T:
    """``make`` of a file beside ``path`` holding ``text`` (so that its includes and song are
    found as ``path``'s), its problems naming ``path``."""
    trial = path.with_name(f".{path.name}.studio-check{path.suffix}")
    try:
        trial.write_text(text, encoding="utf-8")
        return make(trial)
    except (SourceError, PlanningError) as error:
        problems = [p.replace(str(trial), str(path)) for p in error.problems]
        raise type(error)(problems) from None
    except ChoreoError as error:
        raise SourceError(str(error).replace(str(trial), str(path))) from None
    finally:
        trial.unlink(missing_ok=True)
