"""The joint's neighbours simulated as servos holding, moved by the joint: against MuJoCo."""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import arm6_stepped_in_mujoco

from choreo.identify.joint_model import SentMove
from choreo.identify.neighbours import NeighbourReads, neighbour_push
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
ELBOW = joint_load(ARM6, "elbow", [0.0] * 6)
STEP_S = 0.003
# the elbow 20° forward in 60 ms, then back to 5°: the shoulder gives way ~3-4°, the wrist ~1°
MOVES = (SentMove(0.3, 20.0, 0.06), SentMove(1.0, 5.0, 0.05))
TRACE = arm6_stepped_in_mujoco("elbow", MOVES, until_s=1.6)
TIMES = np.arange(1, len(TRACE) + 1) * 0.002
STEPS = int(np.ceil(TIMES[-1] / STEP_S))
AT = np.arange(1, STEPS + 1) * STEP_S


def reads_of(joint: str, *, in_units: bool) -> NeighbourReads:
    """``joint`` read every 8 ms (a neighbour's share of the bus), in whole read units (0.24°)
    or exactly."""
    read_s = TIMES[3::4]
    angle = TRACE[3::4, ARM6.joint_names.index(joint)]
    return NeighbourReads(joint, read_s, np.round(angle / 0.24) * 0.24 if in_units else angle, 0.0)


def pushed(in_units: bool):
    neighbours = [reads_of(n, in_units=in_units) for n in ("shoulder", "wrist_pitch")]
    return neighbour_push(neighbours, ELBOW, TIMES, TRACE[:, 2], STEP_S, STEPS)


@pytest.mark.parametrize(
    ("column", "name", "share"), [(0, "shoulder", 0.9), (1, "wrist_pitch", 0.4)]
)
def test_the_neighbours_yield_under_the_joint_as_in_mujoco_closer_than_their_reads_tell(
    column, name, share
):
    """Moved by the elbow, the shoulder and the wrist_pitch swing as MuJoCo's do, within 3 %
    of their swing at worst; their reads in whole units are further from where they were."""
    modelled = pushed(in_units=True).neighbours_deg[:, column]
    truth = np.interp(AT, TIMES, TRACE[:, ARM6.joint_names.index(name)])
    reads = reads_of(name, in_units=True)
    read_error = np.interp(AT, reads.read_s, reads.read_deg) - truth
    assert np.ptp(truth) > 1.5  # they really move
    assert np.abs(modelled - truth).max() < 0.03 * np.ptp(truth)
    assert np.sqrt(np.mean((modelled - truth) ** 2)) < share * np.sqrt(np.mean(read_error**2))


def test_the_read_units_rounding_does_not_reach_the_joint():
    """What the neighbours push the joint with, from reads in whole units, is what exact reads
    give: the model takes only their slow part from them, where the units' noise is small."""
    rounded, exact = pushed(in_units=True), pushed(in_units=False)
    difference = rounded.torque_nm - exact.torque_nm
    assert np.sqrt(np.mean(difference**2)) < 0.02 * np.sqrt(np.mean(exact.torque_nm**2))
    assert np.sqrt(np.mean(difference**2)) < 0.002  # N·m: a tenth of a small friction


def test_neighbours_free_to_move_lighten_the_joint_and_unread_ones_stand_rigid():
    free = pushed(in_units=False)
    upright = int(np.searchsorted(ELBOW.angles_deg, 0.0))
    own = ELBOW.inertia_kg_m2[upright]
    assert free.joint_inertia_kg_m2[0] < 0.9 * own
    rigid = neighbour_push([], ELBOW, TIMES, TRACE[:, 2], STEP_S, STEPS)
    assert np.all(rigid.torque_nm == 0.0)
    assert rigid.joint_inertia_kg_m2[0] == pytest.approx(own, rel=0.01)


def test_a_neighbours_own_neighbour_swings_with_it_unread():
    """The shoulder steps: its elbow (read) gives way ~6°, and the wrist_pitch the elbow carries
    (not read) swings ~2°, as MuJoCo's does."""
    trace = arm6_stepped_in_mujoco("shoulder", MOVES, until_s=1.6)
    load = joint_load(ARM6, "shoulder", [0.0] * 6)
    elbow = NeighbourReads("elbow", TIMES[3::4], np.round(trace[3::4, 2] / 0.24) * 0.24, 0.0)
    modelled = neighbour_push([elbow], load, TIMES, trace[:, 1], STEP_S, STEPS).neighbours_deg
    for column, name in enumerate(("elbow", "wrist_pitch")):
        truth = np.interp(AT, TIMES, trace[:, ARM6.joint_names.index(name)])
        assert np.ptp(truth) > 1.5
        assert np.abs(modelled[:, column] - truth).max() < 0.03 * np.ptp(truth)
