"""Where each keyframe of a plan is written in the motion file (its item of ``keyframes:``, or the
include that brought it), how its time is written, and which keyframes an edit moved in time."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from choreo.studio import yaml_edit
from choreo.studio.session import Plan

KEPT_S = 0.001  # another keyframe that moved less than this kept its time
MOVED_NAMED = 3  # a warning names this many keyframes that moved, then counts the rest


@dataclass(frozen=True)
class Placed:
    """A keyframe of the plan and the item of the motion file's ``keyframes:`` it comes from."""

    index: int  # in plan.motion.keyframes
    item: int | None  # None: not in this file's list (an include's include)
    alone: bool  # the item is this keyframe alone (not an include or a gait): editable here
    t_s: float  # when it is reached, played seconds


def notation_of(plan: Plan, placed: Placed | None) -> str | None:
    """How ``placed``'s time is written: ``after``, ``t``, ``beat`` or ``bar``; None when it is
    not (as soon as the limits allow) or comes from an include."""
    if placed is None or not placed.alone:
        return None
    keyframe = plan.motion.keyframes[placed.index]
    if keyframe.after_s is not None:
        return "after"
    if keyframe.beat is not None:
        return "bar" if keyframe.beat.by_bar else "beat"
    return "t" if keyframe.t_s is not None else None


def placed_keyframes(text: str, plan: Plan, path: Path) -> list[Placed]:
    """Each keyframe of ``plan`` with the item of ``text``'s ``keyframes:`` it comes from:
    its own, or the include entry that brought it."""
    items = yaml_edit.keyframe_items(text)
    by_line = {item.content_line + 1: i for i, item in enumerate(items)}
    own = Path(path).resolve()
    keyframes = plan.motion.keyframes
    sharing = Counter((Path(k.where.path).resolve(), k.where.line) for k in keyframes)
    placed = []
    for index, (keyframe, t_s) in enumerate(zip(keyframes, plan.keyframe_times_s)):
        where = keyframe.where
        if Path(where.path).resolve() == own and not where.included_at:
            item = by_line.get(where.line)
            alone = item is not None and sharing[(own, where.line)] == 1
        else:
            entry = next((e for e in where.included_at if Path(e.path).resolve() == own), None)
            item, alone = (by_line.get(entry.line) if entry else None), False
        placed.append(Placed(index, item, alone, float(t_s)))
    return placed


def item_text(text: str, item: int) -> str:
    """The lines of the ``item``-th keyframe of ``text``, as written."""
    found = yaml_edit.keyframe_items(text)[item]
    return "\n".join(text.splitlines()[found.first_line : found.last_line + 1])


def others_moved(before: Plan, after: Plan, replaced: int | None, line: int | None) -> str:
    """A warning naming the keyframes other than the one edited that ``change`` moved in time
    (those timed "as soon as the limits allow", or through an include); "" if none. The edit
    replaced the plan's keyframe ``replaced`` (None: added one) and wrote one at ``line``."""
    old = list(before.keyframe_times_s)
    new = list(after.keyframe_times_s)
    old_keyframes = list(before.motion.keyframes)
    if replaced is not None:
        del old[replaced], old_keyframes[replaced]
    edited = [
        i
        for i, k in enumerate(after.motion.keyframes)
        if line is not None and k.where.line == line and not k.where.included_at
    ]
    if edited:
        del new[edited[0]]
    if len(old) != len(new):
        return ""
    moved = [
        (keyframe, t_new - t_old)
        for keyframe, t_old, t_new in zip(old_keyframes, old, new)
        if abs(t_new - t_old) >= KEPT_S
    ]
    if not moved:
        return ""
    named = ", ".join(
        f"{k.where} {abs(shift):.2f} s {'later' if shift > 0 else 'earlier'}"
        for k, shift in moved[:MOVED_NAMED]
    )
    more = f" and {len(moved) - MOVED_NAMED} more" if len(moved) > MOVED_NAMED else ""
    return f"⚠ other keyframes moved (timed as soon as the limits allow): {named}{more}"
