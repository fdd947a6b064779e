"""choreo.preview on every shipped motion (motions/): each is simulated and passes every check,
warnings included. Apart from tests/preview/test_preview.py because these simulations are most of
the preview's test CPU (the hexapod and humanoid ones take seconds each): in one file they bound a
parallel run's wall time, as ``--dist loadfile`` keeps a file on one worker.

This is the one place the shipped motions are simulated: the validate tests elsewhere
(tests/motion/test_motion_file.py, tests/motion/test_music_block.py) pass --no-physics and lean on
this stricter check (no warning either) for the physics. tests/preview/test_travel.py measures
some of the same simulations: shipped_helpers keeps each result for both."""

from __future__ import annotations

import pytest
from shipped_helpers import SHIPPED_MOTIONS, simulated_shipped

from choreo.preview import run_checks


def test_every_robot_has_shipped_motions():
    assert {p.parent.name for p in SHIPPED_MOTIONS} >= {"arm6", "hexapod18", "tonypi"}


@pytest.mark.parametrize("path", SHIPPED_MOTIONS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_the_shipped_motions_pass(path):
    assert run_checks(simulated_shipped(path)) == []
