"""The studio's timeline: where in the motion the page stands, playing it, and drawing the robot
there (the simulated robot, with the plan as a ghost, or the sliders' pose while posing)."""

from __future__ import annotations

import time

import numpy as np

from choreo.studio.page import SPEEDS
from choreo.studio.parts import StudioParts
from choreo.studio.session import Plan

FRAME_S = 1 / 30  # the player redraws the page at 30 frames a second
TIME_SLACK_S = 0.01  # the timeline's ends are shown rounded to its step


class Timeline(StudioParts):
    """Time, play and speed; ``_redraw`` shows the robot at the timeline's time."""

    def _init_timeline(self) -> None:
        self.time_s = 0.0
        self.playing = False
        self.speed = 1.0

    def scrub(self, t_s: float, *, adding: bool = False) -> None:
        """The timeline to ``t_s``; ``adding``: a keyframe is to be added there (pasted), so
        the time may lie past the end, which it will extend."""
        with self._lock:
            plan = self._plan()
            if plan is None:
                return
            end_s = np.inf if adding else plan.end_s
            if not plan.start_s - TIME_SLACK_S <= t_s <= end_s + TIME_SLACK_S:
                self.refuse(
                    f"refused: t {t_s:g} s is outside the timeline "
                    f"{plan.start_s:.2f}..{plan.end_s:.2f} s"
                )
                return
            self.time_s = self._snapped(plan, float(np.clip(t_s, plan.start_s, end_s)))
            self._back_to_the_plan()
            self._redraw(plan)
            self.page.show_joints(plan.planned_deg(self.time_s))
            if self.playing:  # the pages' clocks go on from here
                self.timeline_page.show_play(True, self.time_s, self.speed)

    def _snapped(self, plan: Plan, t_s: float) -> float:
        """``t_s``, or with "snap to beats" the nearest beat of the music."""
        music = plan.motion.music
        if music is None or not self.page.snap.value or t_s < music.grid.beat_times_s[0]:
            return t_s
        grid = music.grid
        return grid.time_of(min(max(round(grid.beat_at(t_s)), 1), grid.beats))

    def toggle_play(self) -> None:
        with self._lock:
            self.playing = not self.playing
            self.page.play.label = "Pause" if self.playing else "Play"
            if self.playing:
                self._back_to_the_plan()
            self.timeline_page.show_play(self.playing, self.time_s, self.speed)
            if not self.playing:  # where it paused
                self._redraw_current()

    def set_speed(self, text: str) -> None:
        if text not in SPEEDS:
            self.refuse(f"refused: speed {text!r} is not one of {', '.join(SPEEDS)}")
            return
        with self._lock:
            self.speed = float(text)
            if self.playing:
                self.timeline_page.show_play(True, self.time_s, self.speed)

    def show_ghost(self, visible: bool) -> None:
        with self._lock:
            if self.view is not None:
                self.view.ghost_visible = visible
            self._redraw_current()

    def _play_loop(self) -> None:
        last = time.monotonic()
        while not self._stop.wait(FRAME_S):
            now = time.monotonic()
            elapsed, last = now - last, now
            with self._lock:
                plan = self._plan()
                if not self.playing or plan is None:
                    continue
                self.time_s += elapsed * self.speed
                if self.time_s > plan.end_s:
                    self.time_s = plan.start_s
                    self.timeline_page.show_play(True, self.time_s, self.speed)
                self._redraw(plan)

    def _redraw_current(self) -> None:
        plan = self._plan()
        if plan is not None:
            self._redraw(plan)

    def _redraw(self, plan: Plan) -> None:
        if self.view is None:
            return
        t = self.time_s
        planned = plan.planned_deg(t)
        if plan.physics is not None:
            qpos = plan.physics.qpos_at(t)
        else:  # simulating: the robot takes the plan's pose where it stands
            qpos = self.view.qpos_with(self.view.qpos, planned)
        if self.posing is not None:
            self.view.show(self.view.qpos_with(qpos, self.posing, self._posed_root), planned)
        else:
            self.view.show(qpos, planned)
        self.page.show_time(t, self._time_text(plan, t))
        if not self.playing:  # while playing, each page keeps time with its own clock
            self.timeline_page.show_time(t)
        if self.driving and self.live is not None:
            self.live.follow(self.posing if self.posing is not None else planned)

    def _time_text(self, plan: Plan, t: float) -> str:
        phase = plan.phase(t)
        text = f"**{t:.2f} s** · {phase}"
        music = plan.motion.music
        if music is not None and t >= 0:
            bar, beat = music.grid.bar_and_beat(music.grid.beat_at(t))
            text += f" · bar {bar} beat {beat:.1f}"
        if self.posing is not None:
            text += " · posing (the sliders' pose; the ghost is the plan)"
        return text
