"""A gripper squeezing what it carries at full torque is a warning that names where it
touches, not a stall: the servo is stopped by the block it holds, as meant."""

from __future__ import annotations

import pytest
from paths import REPO

from choreo.motion.motion_file import load_motion
from choreo.preview import CheckKind, Severity, run_checks, simulate_motion


def test_a_gripper_squeezing_the_block_at_stall_for_seconds_is_a_warning_naming_the_touch(
    tmp_path,
):
    """pick_and_place closing the gripper to 0° on its 30 mm block (the pads meet it at ~20°)
    and holding 2 s: the servo sits at its stall torque for over 5 s while it carries the
    block. Before: a stall error and a tracking error."""
    text = (REPO / "motions" / "arm6" / "pick_and_place.yaml").read_text()
    squeeze = "  - pose: {gripper: 0}\n    after: 0.5\n    hold: 2.0\n"
    text = text.replace("  - pose: {gripper: 16}\n    after: 0.5\n    hold: 0.3\n", squeeze)
    robot = (REPO / "models" / "arm6" / "robot.yaml").as_posix()
    path = tmp_path / "squeeze.yaml"
    path.write_text(text.replace("robot: arm6", f"robot: {robot}"))
    simulated = simulate_motion(load_motion(path))
    results = run_checks(simulated)
    assert [r.severity for r in results] == [Severity.WARNING, Severity.WARNING]
    squeezing, held_open = results
    assert squeezing.kind is CheckKind.SATURATION and squeezing.joint == "gripper"
    assert squeezing.bodies == ("block",) and squeezing.duration_s > 4
    assert squeezing.value == pytest.approx(20, abs=1.5)  # where the pads meet the block
    assert f"touches the block at {squeezing.value:.1f}°" in squeezing.message
    assert held_open.kind is CheckKind.TRACKING_ERROR and "held open by the block" in (
        held_open.message
    )
    (block,) = simulated.props
    assert block.placed and not block.knocked_over and block.dropped_at_s is None
