"""choreo identify made quick for tests of what surrounds the moves and the fit: two short moves
and a two-generation search (the moves and the fit are judged in their own tests)."""

from __future__ import annotations

import sys

from choreo.identify import fit
from choreo.identify.joint_model import SentMove
from choreo.identify.moves import MovePlan


def make_identify_quick(monkeypatch) -> None:
    identify_module = sys.modules[
        "choreo.identify.identify"
    ]  # (the package's name is the function)
    monkeypatch.setattr(fit, "GENERATIONS", 2)

    def short(joint, pose_deg, drop=False):
        return MovePlan((SentMove(0.0, pose_deg + 2.0, 0.2), SentMove(0.5, pose_deg, 0.2)), 0.9)

    monkeypatch.setattr(identify_module, "fit_moves", short)
    monkeypatch.setattr(identify_module, "held_out_moves", short)
