"""The studio's panel without a browser: the sliders show the plan's pose at the scrubbed time,
and the status line says the files' state, then what the last action did."""

from __future__ import annotations

import numpy as np
from studio_helpers import studio_on


def test_the_sliders_show_the_planned_pose_at_the_scrubbed_time(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        plan = studio.session.plan
        studio.scrub(1.3)
        np.testing.assert_allclose(studio.page.pose_deg(), plan.planned_deg(1.3), atol=0.051)
        assert studio.page.time.value == 1.3


def test_the_status_line_says_the_state_then_the_last_refusal(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        studio.refuse("refused: nothing to undo")
        status = studio.page.status.content
        assert "nothing to undo" in status and "⛔" not in status  # the page's fonts may lack it
        # the files' state first (by now simulated), then the refusal, in the refusal's colour
        assert status.index("simulated") < status.index("nothing to undo")
        assert 'role="status"' in status and "#b00020" in status
