"""The studio's edits: the page's keyframe buttons made into writes of the motion file, each
checked before anything is written (``check_loads``) and changing only what it must
(``yaml_edit``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from choreo.core.atomic import write_text_atomically
from choreo.errors import ChoreoError, SourceError
from choreo.motion.motion_file import Motion, load_motion
from choreo.studio import yaml_edit
from choreo.studio.parts import StudioParts
from choreo.studio.session import Plan

BODY_MATCH_DEG = 0.5  # a body: keyframe as loaded may be this far from the pose the handle made


class Editing(StudioParts):
    """Add, update, move and delete keyframes; ``selected`` is the keyframe the page chose."""

    def _init_editing(self) -> None:
        self.selected: int | None = None  # the selected keyframe (index into motion.keyframes)

    def select_keyframe(self, index: int | None) -> None:
        with self._lock:
            plan = self._plan()
            if plan is None or index is None:
                self.selected = None
                return
            self.selected = index
            keyframe, t = plan.keyframe_at(index)
            values = ", ".join(
                f"{name} {angle:g}°"
                for name, angle in zip(plan.motion.robot.joint_names, keyframe.targets_deg)
            )
            label = f" ({keyframe.label})" if keyframe.label else ""
            self.page.show_keyframe(index, f"`{keyframe.where}`{label} at {t:.2f} s: {values}")
            self.scrub(t)

    def add_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            if self.time_s < 0:
                raise yaml_edit.EditRefused("the timeline is in the approach: pick a time >= 0")
            items = self._items(text, plan)
            before = [i for i, t in items if t <= self.time_s + 1e-9]
            after = max(before) if before else None
            new = yaml_edit.add_keyframe(text, after, *self._captured(plan), self._timing(plan))
            self._check_body(new, 0 if after is None else after + 1)
            return new

        self._edit(change, "added a keyframe")

    def update_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            item, where = self._selected_item(text, plan)
            new = yaml_edit.update_keyframe(text, item, where, *self._captured(plan))
            self._check_body(new, item)
            return new

        self._edit(change, "updated the keyframe")

    def _check_body(self, text: str, item: int) -> None:
        """A ``body:`` pose written as the ``item``-th keyframe of ``text`` must mean the pose on
        screen: the file moves the body from the feet the keyframes before it planted, and
        those must be the feet the handle kept (``EditRefused`` if not)."""
        if self.body_goal is None or self.posing is None:
            return
        motion = check_loads(self.session.motion_path, text)
        line = yaml_edit.keyframe_items(text)[item].content_line + 1
        written = [
            k.targets_deg
            for k in motion.keyframes
            if k.where.line == line and not k.where.included_at and k.body is not None
        ]
        if not written or np.abs(np.subtract(written[0], self.posing)).max() > BODY_MATCH_DEG:
            raise yaml_edit.EditRefused(
                "a body: keyframe there would stand on other feet than the pose shown (a body: "
                "pose moves the body from the feet the keyframes before it planted): scrub to "
                "the keyframe it follows, pose the body there, and add it"
            )

    def retime_keyframe(self) -> None:
        self._edit(
            lambda text, plan: yaml_edit.retime_keyframe(
                text, *self._selected_item(text, plan), self._timing(plan)
            ),
            "moved the keyframe",
        )

    def delete_keyframe(self) -> None:
        def change(text: str, plan: Plan) -> str:
            item, _ = self._selected_item(text, plan)
            self.selected = None
            return yaml_edit.delete_keyframe(text, item)

        self._edit(change, "deleted the keyframe")

    def _captured(self, plan: Plan) -> tuple[str, object]:
        """What a keyframe captures: the site a handle placed (``sites:``), else every joint's
        angle (``pose:``)."""
        if self.site_goal is not None:
            site, at_mm = self.site_goal
            return "sites", yaml_edit.sites_mapping(site, at_mm)
        if self.body_goal is not None:
            return "body", yaml_edit.body_mapping(self.body_goal)
        pose = dict(zip(plan.motion.robot.joint_names, (float(a) for a in self._pose())))
        return "pose", yaml_edit.pose_mapping(pose)

    def _timing(self, plan: Plan) -> yaml_edit.Timing:
        """The timeline's time as a keyframe is written: in beats in a dance, else seconds."""
        music = plan.motion.music
        return yaml_edit.timing(self._file_t(plan), music.grid if music else None)

    def _file_t(self, plan: Plan) -> float:
        """The timeline's time as the file writes it (before the motion's speed)."""
        return self.time_s * plan.motion.speed

    def _items(self, text: str, plan: Plan) -> list[tuple[int, float]]:
        """(item index in the file's list, arrival time) of the keyframes written in the file."""
        items = yaml_edit.keyframe_items(text)
        by_line = {item.content_line + 1: i for i, item in enumerate(items)}
        own = self.session.motion_path.resolve()
        found = []
        for keyframe, t in zip(plan.motion.keyframes, plan.keyframe_times_s):
            where = keyframe.where
            if Path(where.path).resolve() == own and not where.included_at:
                if where.line in by_line:
                    found.append((by_line[where.line], t))
        return found

    def _selected_item(self, text: str, plan: Plan) -> tuple[int, str]:
        if self.selected is None:
            raise yaml_edit.EditRefused("select a keyframe first")
        keyframe = plan.motion.keyframes[self.selected]
        where = keyframe.where
        if Path(where.path).resolve() != self.session.motion_path.resolve() or where.included_at:
            raise yaml_edit.EditRefused(f"{where}: written in an included file: edit it there")
        lines = [item.content_line + 1 for item in yaml_edit.keyframe_items(text)]
        shared = sum(k.where == where for k in plan.motion.keyframes)
        if where.line not in lines or shared > 1:
            raise yaml_edit.EditRefused(f"{where}: a block of keyframes: edit it in the text")
        return lines.index(where.line), str(where)

    def _edit(self, change: Callable[[str, Plan], str], done: str) -> None:
        if self._write(change, done):
            self.reload()  # outside the lock: the page stays live while the physics runs

    def _write(self, change: Callable[[str, Plan], str], done: str) -> bool:
        """Write the file as ``change`` makes it; True when the file is to be reloaded (written,
        or changed on disk since the page showed it: then it is not overwritten)."""
        with self._lock:
            path, plan = self.session.motion_path, self._plan()
            if plan is None:
                self.refuse("nothing written: the file has never loaded")
                return False
            if self.session.changed_on_disk():
                self.refuse(
                    f"nothing written: {path} changed on disk since the page showed it; "
                    "reloaded it: look, then make the change again"
                )
                return True
            try:
                text = path.read_text(encoding="utf-8")
                new = change(text, plan)
                check_loads(path, new)
            except (yaml_edit.EditRefused, SourceError) as error:
                self.refuse(f"nothing written: {error}")
                return False
            try:
                write_text_atomically(path, new)
            except (ChoreoError, OSError) as error:  # a folder made read-only, a full disk
                self.refuse(f"nothing written: {error}")
                return False
            self._watcher.seen()
            self.note(f"{done} in {path}")
            return True


def check_loads(path: Path, text: str) -> Motion:
    """The motion ``text`` written to ``path`` would be; ``SourceError`` (naming ``path``) if
    it would not load."""
    trial = path.with_name(f".{path.name}.studio-check{path.suffix}")
    try:
        trial.write_text(text, encoding="utf-8")
        return load_motion(trial)
    except SourceError as error:
        raise SourceError([p.replace(str(trial), str(path)) for p in error.problems]) from None
    except ChoreoError as error:
        raise SourceError(str(error).replace(str(trial), str(path))) from None
    finally:
        trial.unlink(missing_ok=True)
