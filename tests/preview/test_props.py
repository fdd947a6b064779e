"""Free props (a ``props:`` box with ``mass_kg``): bodies that fall, are pushed, gripped and
carried; the robot touching one is expected, and the report says where each went."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import paths
import pytest
from paths import REPO

from choreo.motion.motion_file import load_motion
from choreo.motion.scene import Prop
from choreo.preview import CheckKind, Severity, prop_outcomes, run_checks, simulate_motion

DATA = paths.DATA / "preview"
MOTIONS = DATA / "motions"
ARM6 = REPO / "motions" / "arm6"


def with_props(path: Path, *props: Prop):
    return dataclasses.replace(load_motion(path), props=props)


def test_a_free_prop_falls_and_comes_to_rest_on_the_floor():
    """Dropped from 5 cm beside the arm (out of its reach), a free block lands on the floor: its
    bottom face ends at z = 0, 50 mm lower, upright, and nothing is reported."""
    block = Prop("block", (0.03, 0.03, 0.03), (-0.2, 0.0, 0.05), mass_kg=0.02)
    simulated = simulate_motion(with_props(MOTIONS / "fine.yaml", block))
    assert run_checks(simulated) == []
    (outcome,) = simulated.props
    assert prop_outcomes(simulated.rollout) == [outcome]
    assert outcome.end_m[2] == pytest.approx(0.0, abs=0.002)  # it fell during settling
    assert outcome.start_m[2] == pytest.approx(0.0, abs=0.002)
    assert not outcome.lifted and not outcome.knocked_over


def test_pushing_a_free_prop_is_expected_pushing_a_fixed_one_is_not():
    """floor.yaml leans the forearm down onto the floor 20 cm out. A fixed block there is hit
    (an error naming it); a free 50 g block there is pressed on and shoved, which is expected:
    no error."""
    fixed = Prop("block", (0.2, 0.2, 0.05), (0.2, 0.0, 0.0))
    free = dataclasses.replace(fixed, mass_kg=0.05)
    fixed_hits = [
        r
        for r in run_checks(simulate_motion(with_props(MOTIONS / "floor.yaml", fixed)))
        if "block" in r.bodies
    ]
    assert fixed_hits and fixed_hits[0].kind is CheckKind.FLOOR_CONTACT
    simulated = simulate_motion(with_props(MOTIONS / "floor.yaml", free))
    results = run_checks(simulated)
    assert not [r for r in results if "block" in r.bodies]
    (outcome,) = simulated.props
    assert outcome.displacement_m > 0.001  # shoved (pinned to the floor under the forearm)


def test_a_prop_not_left_at_its_place_target_is_an_error():
    """The shipped pick_and_place with the place target moved 10 cm further out: the block is
    set down where the arm goes, ~100 mm from that target."""
    motion = load_motion(ARM6 / "pick_and_place.yaml")
    block = motion.props[0]
    x, y, z = block.place_at_m
    moved = dataclasses.replace(block, place_at_m=(x + 0.1, y, z))
    results = run_checks(simulate_motion(dataclasses.replace(motion, props=(moved,))))
    (miss,) = [r for r in results if r.kind is CheckKind.PROP]
    assert miss.severity is Severity.ERROR and miss.value == pytest.approx(100, abs=12)
    assert "from its place target" in miss.message


def pick_and_place_variant(tmp_path: Path, old: str, new: str):
    text = (ARM6 / "pick_and_place.yaml").read_text()
    assert old in text
    robot = (ARM6.parents[1] / "models" / "arm6" / "robot.yaml").as_posix()
    path = tmp_path / "variant.yaml"
    path.write_text(text.replace(old, new).replace("robot: arm6", f"robot: {robot}"))
    return load_motion(path)


def test_a_grip_that_does_not_squeeze_never_lifts_the_block(tmp_path):
    """Closing only to 21°, where the pads barely meet a 30 mm block (~20°), squeezes it with
    almost no force (inside the servo's dead band): friction cannot lift it, so it stays where
    it was, 245 mm from its target."""
    motion = pick_and_place_variant(tmp_path, "gripper: 16}", "gripper: 21}")
    simulated = simulate_motion(motion)
    (result,) = [r for r in run_checks(simulated) if r.kind is CheckKind.PROP]
    assert result.severity is Severity.ERROR and "from its place target" in result.message
    (outcome,) = simulated.props
    assert not outcome.lifted and outcome.displacement_m < 0.005


def test_a_block_let_go_in_mid_air_is_dropped_an_error_of_its_own(tmp_path):
    """The hand opens at the top of the lift: the block was lifted, then it falls. Without a
    ``place_at_m`` to miss, the drop alone is an error: no motion means to let what it lifted
    fall. (With the grip's contacts holding what friction holds, a light squeeze no longer lets a
    block slip out on the way: it holds it or never lifts it, tests/preview/test_model.py.)"""
    top = "  - sites: {tool: {at: [102.8, 122.6, 90], pitch: -70}}\n    after: 0.4\n"
    opened = top.replace("\n    after", "\n    pose: {gripper: 40}\n    after")
    motion = pick_and_place_variant(tmp_path, top, opened)
    block = dataclasses.replace(motion.props[0], place_at_m=None)
    simulated = simulate_motion(dataclasses.replace(motion, props=(block,)))
    results = [r for r in run_checks(simulated) if r.kind is CheckKind.PROP]
    assert [r.severity for r in results] == [Severity.ERROR]
    assert "dropped" in results[0].message
    (outcome,) = simulated.props
    assert outcome.lifted and outcome.dropped_at_s == results[0].time_s
