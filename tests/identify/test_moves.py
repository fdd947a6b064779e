"""Each joint's test moves: inside its limits, with what each part is for."""

from __future__ import annotations

import pytest

from choreo.identify.joint_model import SentMove, Unload
from choreo.identify.moves import MARGIN_DEG, fit_moves, held_out_moves
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")


@pytest.mark.parametrize("name, pose", [("elbow", 0.0), ("gripper", 0.0), ("shoulder", 88.0)])
def test_every_move_stays_inside_the_limits_with_a_margin(name, pose):
    joint = ARM6.joint(name)
    for moves in (fit_moves(joint, pose, drop=True), held_out_moves(joint, pose)):
        targets = [c.target_deg for c in moves.commands if isinstance(c, SentMove)]
        assert min(targets) >= joint.limits.min_deg + MARGIN_DEG - 1e-9
        assert max(targets) <= joint.limits.max_deg - MARGIN_DEG + 1e-9
        times = [c.at_s for c in moves.commands]
        assert times == sorted(times) and moves.duration_s > times[-1]


def test_the_fit_moves_have_slow_triangles_small_reversals_steps_and_holds():
    moves = fit_moves(ARM6.joint("elbow"), 0.0)
    sent = [c for c in moves.commands if isinstance(c, SentMove)]
    speeds = {
        round(abs(b.target_deg - a.target_deg) / b.time_s)
        for a, b in zip(sent, sent[1:])
        if b.time_s >= 0.5
    }
    assert 10 in speeds  # a slow triangle
    sizes = {round(abs(b.target_deg - a.target_deg), 2) for a, b in zip(sent, sent[1:])}
    assert {0.5, 1.0, 2.0} <= sizes  # small reversals
    assert {0.0, 0.15, 0.4} <= {c.time_s for c in sent}  # steps at several move times
    assert not any(isinstance(c, Unload) for c in moves.commands)  # no drop unless asked


def test_a_drop_only_when_asked():
    moves = fit_moves(ARM6.joint("elbow"), 0.0, drop=True)
    assert sum(isinstance(c, Unload) for c in moves.commands) == 1
