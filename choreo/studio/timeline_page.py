"""The timeline at the bottom of the studio's page, on the studio's side: what it shows (the
plan, the time, playing, the status line) published to its page (``timeline_server``), and what
the page asks (``timeline_requests``) done with the studio's own operations."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence, Sized
from pathlib import Path
from typing import TYPE_CHECKING

from choreo.motion.music_block import Music
from choreo.studio.session import Plan, Reload
from choreo.studio.timeline_requests import Request
from choreo.studio.timeline_server import TimelineServer
from choreo.studio.timeline_state import keyframe_of, song_peaks, timeline_state
from choreo.studio.watch import stamp

if TYPE_CHECKING:
    from choreo.studio.server import Studio


class TimelinePage:
    """The studio's timeline page: what it shows (``show_*``, from the studio's threads) and
    what it asks, done with the studio's own operations (select, scrub, move here, delete,
    add, undo), so an edit from the timeline is the edit the panel's buttons make, checked
    and journalled the same way."""

    def __init__(self, studio: Studio):
        self._studio = studio
        self.server = TimelineServer(self.handle, self._song)
        self._peaks: tuple[tuple | None, tuple[int, ...]] = (None, ())

    @property
    def port(self) -> int:
        return self.server.port

    def start(self) -> None:
        self.server.start()

    def close(self) -> None:
        self.server.close()

    def _song(self) -> Path | None:
        plan = self._studio.session.plan
        return plan.motion.music.song if plan is not None and plan.motion.music else None

    def show_plan(self, plan: Plan, version: int, limbs: Sequence[tuple[str, Sequence[int]]]):
        state = timeline_state(plan, version, limbs, self._song_peaks(plan.motion.music))
        self.server.publish("state", state)

    def _song_peaks(self, music: Music | None) -> tuple[int, ...]:
        key = None if music is None else (music.song, stamp(music.song))
        if key != self._peaks[0]:
            self._peaks = (key, song_peaks(music))
        return self._peaks[1]

    def show_time(self, t_s: float) -> None:
        self.server.publish("time", {"t": round(t_s, 4)})

    def show_play(self, playing: bool, t_s: float, speed: float) -> None:
        self.server.publish("play", {"playing": playing, "t": round(t_s, 4), "speed": speed})

    def show_status(self, text: str, kind: str = "") -> None:
        self.server.publish("status", {"text": text, "kind": kind})

    # --- what the page asks ----------------------------------------------------------------

    def handle(self, request: Request) -> None:
        studio = self._studio
        if request.version is not None and request.version != studio.session.version:
            studio.refuse(
                f"{request.op}: the page showed reload {request.version}, the file is now at "
                f"reload {studio.session.version}: look again, then {request.op} again"
            )
            return
        if request.op == "scrub" and request.t_s is not None:
            studio.scrub(request.t_s)
        elif request.op == "play":
            studio.toggle_play()
        elif request.op == "select":
            self._select(request.indices)
        elif request.op == "finding":
            self._name_finding(request.indices[0])
        elif request.op == "move":
            self._move([(p.index, p.t_s) for p in request.placed if p.index is not None])
        elif request.op == "delete":
            self._delete(request.indices)
        elif request.op == "add":
            studio.add_keyframe()
        elif request.op == "paste":
            self._paste([(p.t_s, p.pose) for p in request.placed if p.pose is not None])
        elif request.op == "undo":
            studio.undo()
        elif request.op == "redo":
            studio.redo()

    def _keyframes(self) -> int:
        plan = self._studio.session.plan
        return len(plan.motion.keyframes) if plan is not None else 0

    def _select(self, indices: Sequence[int]) -> None:
        """One keyframe selected is the panel's selection too (Update acts on it); several,
        or none, leave the panel none."""
        studio, count = self._studio, self._keyframes()
        if any(i >= count for i in indices):
            studio.refuse(f"refused: the motion has {count} keyframes, not {max(indices) + 1}")
            return
        studio.select_keyframe(indices[0] if len(indices) == 1 else None)

    def _name_finding(self, index: int) -> None:
        """A finding clicked: the playhead goes there; the status line says it and the
        keyframe it belongs to."""
        studio = self._studio
        plan = studio.session.plan
        if plan is None or index >= len(plan.findings):
            studio.refuse(f"refused: there is no finding {index + 1}")
            return
        finding = plan.findings[index]
        keyframe = plan.motion.keyframes[keyframe_of(plan.keyframe_times_s, finding.time_s)]
        studio.scrub(finding.time_s)
        studio.note(
            f"{finding.time_s:.2f} s {finding.severity.value}: {finding.message} "
            f"(keyframe at {keyframe.where})"
        )

    def _done(self, edit: Callable[[], None]) -> bool:
        """Make one edit; whether it was written (the file reloaded)."""
        version = self._studio.session.version
        edit()
        return self._studio.session.version != version

    def _move(self, moves: Sequence[tuple[int, float]]) -> None:
        """Keyframes dragged (index, to time s), each moved as Move keyframe here does: those
        moving later from the last, those moving earlier from the first, so none passes
        another on the way; the first refusal stops the rest. One step to undo."""
        studio = self._studio
        plan = studio.session.plan
        if plan is None or any(i >= len(plan.keyframe_times_s) for i, _ in moves):
            studio.refuse(f"refused: the motion has {self._keyframes()} keyframes")
            return
        later = bool(moves) and moves[0][1] > plan.keyframe_times_s[moves[0][0]]
        with studio.journal.one_step(f"moved {count(moves, 'keyframe')}"):
            for index, t_s in sorted(moves, reverse=later):
                studio.select_keyframe(index)
                studio.scrub(t_s)
                if not self._done(studio.retime_keyframe):
                    return

    def _delete(self, indices: Sequence[int]) -> None:
        """Keyframes deleted as Delete keyframe does, the last first (the numbers of the
        others stay). One step to undo."""
        studio = self._studio
        if any(i >= self._keyframes() for i in indices):
            studio.refuse(f"refused: the motion has {self._keyframes()} keyframes")
            return
        with studio.journal.one_step(f"deleted {count(set(indices), 'keyframe')}"):
            for index in sorted(set(indices), reverse=True):
                studio.select_keyframe(index)
                if not self._done(studio.delete_keyframe):
                    return

    def _paste(self, keyframes: Sequence[tuple[float, Mapping[str, float]]]) -> None:
        """Copied poses (time s, joint -> degrees) added as Add keyframe does, earliest first.
        One step to undo."""
        studio = self._studio
        with studio.journal.one_step(f"pasted {count(keyframes, 'keyframe')}"):
            for t_s, pose in sorted(keyframes, key=lambda k: k[0]):
                studio.scrub(t_s, adding=True)  # past the end too: the phrase extends it
                if not studio.take_angles(pose) or not self._done(studio.add_keyframe):
                    return


def count(things: Sized, noun: str) -> str:
    """ "3 keyframes", "1 keyframe"."""
    return f"{len(things)} {noun}{'s' * (len(things) != 1)}"


def reload_status(result: Reload, plan: Plan | None) -> tuple[str, str]:
    """The status line's first part after a reload, and its kind ("failed" or "")."""
    if result.problems:
        kept = " (the last good plan stays on screen)" if plan is not None else ""
        more = len(result.problems) - 1
        first = result.problems[0] + (f" (and {more} more, listed below)" if more else "")
        return f"reload {result.version} failed: {first}{kept}", "failed"
    assert plan is not None
    physics = plan.physics
    if physics is None:
        return f"reload {result.version} planned: {plan.end_s:.2f} s; simulating…", ""
    findings = physics.findings
    errors = sum(f.severity.value == "error" for f in findings)
    found = (
        f"{len(findings)} finding{'s' * (len(findings) != 1)}"
        + (f" ({errors} error{'s' * (errors != 1)})" if errors else "")
        if findings
        else "no findings: the simulated robot follows the plan"
    )
    took = f"simulated in {physics.took_s:.2f} s"
    return f"reload {result.version} {took}: {plan.end_s:.2f} s, {found}", ""
