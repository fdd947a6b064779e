"""The studio's edits: the page's keyframe buttons made into writes of the motion file.

Each write is checked before anything is written: the file as it would be must load and plan
(else the page says why, and the nearest time that works). A keyframe is found in the file
again on every reload; while the page shows a plan older than the file, nothing is written. An
edit changes only what it must (``yaml_edit``): a keyframe added or moved is timed as its
neighbours are (``after:``, ``t:``, ``bar:``/``beat:``) and the next one's ``after:`` is
rewritten so that it keeps its time. Every write is a step of the ``journal``, to undo.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from choreo.core.atomic import write_text_atomically
from choreo.errors import ChoreoError
from choreo.motion.motion_file import Keyframe
from choreo.studio import yaml_edit
from choreo.studio.journal import Journal, JournalRefused, Step
from choreo.studio.keyframe_places import (
    Placed,
    item_text,
    notation_of,
    others_moved,
    placed_keyframes,
)
from choreo.studio.nearest import STANDS_S, nearest_time
from choreo.studio.parts import StudioParts
from choreo.studio.session import Plan
from choreo.studio.trial import check_loads, check_plans
from choreo.studio.yaml_edit import EditRefused

BODY_MATCH_DEG = 0.5  # a body: keyframe as loaded may be this far from the pose the handle made
CHANGED_DEG = 0.05  # a joint moved less than this (half the sliders' step) did not change


@dataclass(frozen=True)
class Change:
    """The file as an edit writes it, and what the check before writing needs to know."""

    text: str
    line: int | None  # where the keyframe added, moved or changed is written (1-based)
    replaced: int | None  # the plan's keyframe it replaces (None: one is added)
    retry: Callable[[float], Change] | None = None  # the same edit at another time (played s)
    window: tuple[float, float] = (0.0, 0.0)  # the times it may take: between its neighbours


@dataclass(frozen=True)
class Selection:
    """The selected keyframe as written: found again, by its text, in the file as reloaded."""

    item: int
    text: str
    t_s: float  # when it was reached (the timeline stood there: it follows the keyframe)


class Editing(StudioParts):
    """Add, update, move, delete, undo and redo; ``selected`` is the keyframe the page chose
    (an index into the shown plan's keyframes, found again on every reload)."""

    def _init_editing(self) -> None:
        self.selected: int | None = None
        self._selection: Selection | None = None
        self.journal = Journal(self.session.motion_path)

    # --- which keyframe -----------------------------------------------------------------------

    def select_keyframe(self, index: int | None) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None or index is None or not 0 <= index < len(plan.motion.keyframes):
                self._select(None)
                return
            self._select(index)
            self.scrub(plan.keyframe_times_s[index])

    def _select(self, index: int | None) -> None:
        """``index`` becomes the selected keyframe, remembered by its text in the file."""
        plan = self._plan()
        self.selected, self._selection = index, None
        if plan is None or index is None:
            self.page.show_keyframe(None, "")
            return
        keyframe, t = plan.keyframe_at(index)
        values = ", ".join(
            f"{name} {angle:g}°"
            for name, angle in zip(plan.motion.robot.joint_names, keyframe.targets_deg)
        )
        label = f" ({keyframe.label})" if keyframe.label else ""
        self.page.show_keyframe(index, f"`{keyframe.where}`{label} at {t:.2f} s: {values}")
        text = self._read_text() if self.session.plan_is_current() else None
        if text is not None:
            placed = self._placed(text, plan)[index]
            if placed.item is not None:
                self._selection = Selection(placed.item, item_text(text, placed.item), t)

    def _follow_selection(self, plan: Plan) -> None:
        """After a reload: the selected keyframe is the item with the text it had (the nearest
        such), wherever it is now; none if it is gone. A timeline that stood at it stays at it,
        unless the robot is being posed."""
        selection = self._selection
        if selection is None:
            if self.selected is not None and self.selected >= len(plan.motion.keyframes):
                self._select(None)
            return
        text = self._read_text()
        try:
            items = yaml_edit.keyframe_items(text or "")
        except (yaml_edit.EditRefused, ValueError):
            items = ()
        same = [i for i in range(len(items)) if item_text(text or "", i) == selection.text]
        if not same or text is None:
            self._select(None)
            return
        item = min(same, key=lambda i: abs(i - selection.item))
        found = [p for p in self._placed(text, plan) if p.item == item and p.alone]
        if found and self.posing is None and abs(self.time_s - selection.t_s) < STANDS_S:
            self.time_s = found[0].t_s
        self._select(found[0].index if found else None)

    def _read_text(self) -> str | None:
        try:
            return self.session.motion_path.read_bytes().decode("utf-8")
        except (OSError, UnicodeDecodeError):
            return None

    def _placed(self, text: str, plan: Plan) -> list[Placed]:
        return placed_keyframes(text, plan, self.session.motion_path)

    def _selected(self, text: str, plan: Plan) -> tuple[Placed, str]:
        """The selected keyframe and its ``path:line:col``, if it can be edited here."""
        if self.selected is None:
            raise EditRefused("select a keyframe first")
        placed = self._placed(text, plan)[self.selected]
        where = plan.motion.keyframes[self.selected].where
        if placed.item is None or where.included_at:
            raise EditRefused(f"{where}: written in an included file: edit it there")
        if not placed.alone:
            raise EditRefused(f"{where}: part of a gait block: edit it in the text")
        return placed, str(where)

    # --- the edits ----------------------------------------------------------------------------

    def add_keyframe(self) -> None:
        self._edit(self._adding, "added a keyframe")

    def _adding(self, text: str, plan: Plan) -> Change:
        if self.time_s < 0:
            raise EditRefused("the timeline is in the approach: pick a time >= 0")
        placed = self._placed(text, plan)
        standing = [p for p in placed if abs(p.t_s - self.time_s) < STANDS_S]
        if standing:
            where = plan.motion.keyframes[standing[0].index].where
            self._select(standing[0].index)
            raise EditRefused(
                f"keyframe {standing[0].index + 1} ({where}) stands at {self.time_s:.2f} s: "
                "selected it: Update writes the pose into it"
            )
        key, value = self._captured_new(plan, placed)

        def at(t_s: float) -> Change:
            before = [p for p in placed if p.t_s <= t_s]
            later = [p for p in placed if p.t_s > t_s]
            previous = before[-1] if before else None
            following = later[0] if later else None
            notation = next(
                (n for n in (notation_of(plan, previous), notation_of(plan, following)) if n),
                "beat" if plan.motion.music is not None else "t",
            )
            timing = self._time_as(plan, notation, t_s, previous)
            new = self._keep_next(text, plan, following, t_s, hold_s=0.0)
            after = max((p.item for p in before if p.item is not None), default=None)
            new = yaml_edit.add_keyframe(new, after, key, value, timing)
            item = 0 if after is None else after + 1
            line = yaml_edit.keyframe_items(new)[item].content_line + 1
            low = previous.t_s if previous is not None else 0.0
            high = following.t_s if following is not None else plan.end_s
            return Change(new, line, None, at, (low, high))

        change = at(self.time_s)
        self._check_body(change.text, change.line)
        return change

    def update_keyframe(self) -> None:
        self._edit(self._updating, "updated the keyframe")

    def _updating(self, text: str, plan: Plan) -> Change:
        placed, where = self._selected(text, plan)
        assert placed.item is not None
        keyframe = plan.motion.keyframes[placed.index]
        if self.site_goal is not None:
            goal = self.site_goal
            new = yaml_edit.update_site(text, placed.item, where, goal.site, goal.position_mm)
        elif self.body_goal is not None:
            body = yaml_edit.body_mapping(self.body_goal)
            new = yaml_edit.update_keyframe(text, placed.item, where, "body", body)
        else:
            new = self._pose_update(text, plan, placed.item, where, keyframe)
        line = yaml_edit.keyframe_items(new)[placed.item].content_line + 1
        self._check_body(new, line)
        return Change(new, line, placed.index)

    def _pose_update(self, text: str, plan: Plan, item: int, where: str, keyframe: Keyframe) -> str:
        if self.posing is None:
            raise EditRefused(
                "nothing to update: the page shows the plan; pose the robot first (a slider, a "
                "named pose, a handle)"
            )
        names = plan.motion.robot.joint_names
        was = dict(zip(names, keyframe.targets_deg))
        changed = {
            name: float(angle)
            for name, angle in zip(names, self.posing)
            if abs(float(angle) - was[name]) >= CHANGED_DEG
        }
        if not changed:
            raise EditRefused(f"nothing to update: {where} has this pose already")
        return yaml_edit.update_pose(text, item, where, changed, was)

    def retime_keyframe(self) -> None:
        self._edit(self._moving, "moved the keyframe")

    def _moving(self, text: str, plan: Plan) -> Change:
        placed, where = self._selected(text, plan)
        item = placed.item
        assert item is not None
        everything = self._placed(text, plan)
        previous = everything[placed.index - 1] if placed.index > 0 else None
        following = everything[placed.index + 1] if placed.index + 1 < len(everything) else None
        keyframe = plan.motion.keyframes[placed.index]
        notation = (
            notation_of(plan, placed)
            or notation_of(plan, previous)
            or ("beat" if plan.motion.music is not None else "t")
        )
        low = previous.t_s if previous is not None else 0.0
        high = following.t_s if following is not None else float("inf")

        def at(t_s: float) -> Change:
            if not low < t_s < high and not (previous is None and t_s == 0):
                upto = f"{high:.2f} s" if following is not None else "the end"
                raise EditRefused(
                    f"{where} moves between the keyframes either side of it, {low:.2f} s and "
                    f"{upto}: to pass one, delete it and add it there"
                )
            new = self._keep_next(text, plan, following, t_s, keyframe.hold_s)
            timing = self._time_as(plan, notation, t_s, previous)
            new = yaml_edit.retime_keyframe(new, item, where, timing)
            line = yaml_edit.keyframe_items(new)[item].content_line + 1
            return Change(new, line, placed.index, at, (low, min(high, plan.end_s)))

        return at(self.time_s)

    def delete_keyframe(self) -> None:
        self._edit(self._deleting, "deleted the keyframe")

    def _deleting(self, text: str, plan: Plan) -> Change:
        placed, _ = self._selected(text, plan)
        assert placed.item is not None
        everything = self._placed(text, plan)
        previous = everything[placed.index - 1] if placed.index > 0 else None
        following = everything[placed.index + 1] if placed.index + 1 < len(everything) else None
        new = text
        if following is not None:  # it keeps its time, now after the one before the deleted
            leave_s = self._leave_file_s(plan, previous) if previous is not None else 0.0
            new = self._rewrite_after(new, plan, following, leave_s)
        return Change(yaml_edit.delete_keyframe(new, placed.item), None, placed.index)

    # --- timing -------------------------------------------------------------------------------

    def _time_as(
        self, plan: Plan, notation: str, t_s: float, previous: Placed | None
    ) -> dict[str, int | float]:
        """Played time ``t_s`` as a keyframe after ``previous`` writes it in ``notation``."""
        music = plan.motion.music
        leave_s = self._leave_file_s(plan, previous) if previous is not None else 0.0
        return yaml_edit.written_time(
            notation, t_s * plan.motion.speed, leave_s, music.grid if music else None
        )

    @staticmethod
    def _leave_file_s(plan: Plan, placed: Placed) -> float:
        """When ``placed`` is left (reached, then held), in the file's seconds."""
        return placed.t_s * plan.motion.speed + plan.motion.keyframes[placed.index].hold_s

    def _keep_next(
        self, text: str, plan: Plan, following: Placed | None, t_s: float, hold_s: float
    ) -> str:
        """``text`` with the keyframe after a keyframe now at played ``t_s`` (held ``hold_s``)
        keeping its time: its ``after:`` rewritten (a ``t:`` or a beat keeps it by itself)."""
        if following is None:
            return text
        return self._rewrite_after(text, plan, following, t_s * plan.motion.speed + hold_s)

    def _rewrite_after(self, text: str, plan: Plan, placed: Placed, leave_s: float) -> str:
        keyframe = plan.motion.keyframes[placed.index]
        if keyframe.after_s is None or placed.item is None or not placed.alone:
            return text  # a keyframe timed otherwise: the check before writing says if it moves
        after_s = placed.t_s * plan.motion.speed - leave_s
        if after_s < 0:
            raise EditRefused(
                f"{keyframe.where} would have to be reached before the keyframe before it is "
                "left: pick an earlier time"
            )
        where = str(keyframe.where)
        timing = {"after": yaml_edit.number(after_s, yaml_edit.TIME_DECIMALS)}
        return yaml_edit.retime_keyframe(text, placed.item, where, timing)

    # --- what a new keyframe holds ------------------------------------------------------------

    def _captured_new(self, plan: Plan, placed: list[Placed]) -> tuple[str, object]:
        """What a new keyframe captures: the site a handle placed (``sites:``), the body's pose
        (``body:``), else the joints that differ from the keyframe before it (``pose:``: the
        others carry on from it)."""
        if self.site_goal is not None:
            goal = self.site_goal
            return "sites", yaml_edit.sites_mapping(goal.site, goal.position_mm, goal.pitch_deg)
        if self.body_goal is not None:
            return "body", yaml_edit.body_mapping(self.body_goal)
        robot = plan.motion.robot
        pose = dict(zip(robot.joint_names, (float(a) for a in self._pose())))
        before = [p for p in placed if p.t_s <= self.time_s]
        if before:
            carried = plan.motion.keyframes[before[-1].index].targets_deg
            changed = {
                name: angle
                for (name, angle), was in zip(pose.items(), carried)
                if abs(angle - was) >= CHANGED_DEG
            }
            pose = changed or pose
        return "pose", yaml_edit.pose_mapping(pose)

    def _check_body(self, text: str, line: int | None) -> None:
        """A ``body:`` pose written at ``line`` of ``text`` must mean the pose on screen: the
        file moves the body from the feet the keyframes before it planted, and those must be
        the feet the handle kept (``EditRefused`` if not)."""
        if self.body_goal is None or self.posing is None:
            return
        motion = check_loads(self.session.motion_path, text)
        written = [
            k.targets_deg
            for k in motion.keyframes
            if k.where.line == line and not k.where.included_at and k.body is not None
        ]
        if not written or np.abs(np.subtract(written[0], self.posing)).max() > BODY_MATCH_DEG:
            raise EditRefused(
                "a body: keyframe there would stand on other feet than the pose shown (a body: "
                "pose moves the body from the feet the keyframes before it planted): scrub to "
                "the keyframe it follows, pose the body there, and add it"
            )

    # --- writing ------------------------------------------------------------------------------

    def _edit(self, change: Callable[[str, Plan], Change], done: str) -> None:
        if self._write(change, done):
            self.reload()  # outside the lock: the page stays live while the physics runs

    def _write(self, make: Callable[[str, Plan], Change], done: str) -> bool:
        """Write the file as ``make`` changes it, if it loads and plans; True when the file is
        to be reloaded (written, or changed on disk since the page showed it)."""
        with self._lock:
            path, plan = self.session.motion_path, self._plan()
            if plan is None:
                self.refuse("nothing written: the file has never loaded")
                return False
            if not self.session.plan_is_current():
                if self.session.changed_on_disk():
                    self.refuse(
                        f"nothing written: {path} changed on disk since the page showed it; "
                        "reloaded it: look, then make the change again"
                    )
                    return True
                self.refuse(
                    f"nothing written: the page shows the last plan that worked, older than "
                    f"{path} as saved, which does not load or plan: fix the file (or Undo) first"
                )
                return False
            try:
                before = path.read_bytes()
                text = before.decode("utf-8")
                change = make(text, plan)
                if change.text == text:
                    raise EditRefused(f"{path} says this already")
                trial = self._checked(plan, change)
            except (EditRefused, ChoreoError, UnicodeDecodeError) as error:
                self.refuse(f"nothing written: {error}")
                return False
            try:
                with self._watcher.writing():
                    write_text_atomically(path, change.text)
            except (ChoreoError, OSError) as error:  # a folder made read-only, a full disk
                self.refuse(f"nothing written: {error}")
                return False
            self.journal.record(before, path.read_bytes(), done)
            self._selection = self._selection_after(change)
            if self._selection is None:
                self.selected = None
            moved = others_moved(plan, trial, change.replaced, change.line)
            self.note(f"{done} in {path}" + (f"; {moved}" if moved else ""))
            return True

    def _selection_after(self, change: Change) -> Selection | None:
        """The keyframe an edit wrote stays (or becomes) the selected one."""
        if change.line is None:
            return None
        items = yaml_edit.keyframe_items(change.text)
        item = next(i for i, it in enumerate(items) if it.content_line + 1 == change.line)
        return Selection(item, item_text(change.text, item), self.time_s)

    def _checked(self, plan: Plan, change: Change) -> Plan:
        """The plan of the file as ``change`` writes it; ``EditRefused`` saying why it would not
        load or plan, and for an edit at a time, the nearest time that works."""
        path = self.session.motion_path
        try:
            return check_plans(path, change.text)
        except ChoreoError as error:
            problems = getattr(error, "problems", None) or [str(error)]
        why = problems[0] + (f" (and {len(problems) - 1} more)" if len(problems) > 1 else "")
        if change.retry is None:
            raise EditRefused(f"the file would not load or plan: {why}")
        retry = change.retry
        search = nearest_time(
            path, change.text, self.time_s, lambda t: retry(t).text, change.window, change.line
        )
        raise EditRefused(f"at {self.time_s:.2f} s it would not plan: {why}; {search.hint()}")

    # --- the journal --------------------------------------------------------------------------

    def undo(self) -> None:
        self._from_journal(self.journal.undo, "undid")

    def redo(self) -> None:
        self._from_journal(self.journal.redo, "redid")

    def _from_journal(self, restore: Callable[[], Step], done: str) -> None:
        with self._lock:
            try:
                with self._watcher.writing():
                    step = restore()
            except JournalRefused as error:
                self.refuse(str(error))
                return
            self.note(f"{done} '{step.what}' in {self.session.motion_path}")
        self.reload()
