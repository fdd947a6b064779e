"""The studio's timeline without a browser: scrubbing within the plan (a time outside it refused
with the range), play and pause, and the speeds the page offers."""

from __future__ import annotations

import pytest
from studio_helpers import refused, studio_on

from choreo.studio.page import SPEEDS


def test_scrubbing_outside_the_timeline_is_refused_with_its_range(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        plan = studio.session.plan
        studio.scrub(1.0)
        studio.scrub(plan.end_s + 5)
        assert refused(studio) == (
            f"⛔ refused: t {plan.end_s + 5:g} s is outside the timeline "
            f"{plan.start_s:.2f}..{plan.end_s:.2f} s"
        )
        assert studio.time_s == pytest.approx(1.0)  # where it was


def test_play_and_pause_and_only_the_offered_speeds(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        studio.toggle_play()
        assert studio.playing and studio.page.play.label == "Pause"
        studio.toggle_play()
        assert not studio.playing and studio.page.play.label == "Play"
        studio.set_speed("2")
        assert studio.speed == 2.0
        studio.set_speed("3")
        assert refused(studio) == f"⛔ refused: speed '3' is not one of {', '.join(SPEEDS)}"
        assert studio.speed == 2.0
