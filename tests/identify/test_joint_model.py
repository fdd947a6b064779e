"""The servo on its joint, simulated for many candidates at once."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from identify_helpers import arm6_stepped_in_mujoco

from choreo.identify.fit import assumed_figures
from choreo.identify.joint_model import (
    SentMove,
    SupplyReads,
    Trial,
    Unload,
    figures_of,
    simulate,
    supply_sag,
)
from choreo.identify.neighbours import NeighbourReads
from choreo.preview.actuator import actuator_params
from choreo.preview.joint_load import joint_load
from choreo.preview.model import apply_servo_models, index_joints, load_model
from choreo.preview.start import start_state
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
YAW = actuator_params(ARM6)[0]
LOAD = joint_load(ARM6, "base_yaw", [0.0] * 6)  # turning about the vertical: no gravity


def trial(*commands: SentMove, until_s: float = 1.0) -> Trial:
    reads = np.arange(0.0, until_s, 0.002)
    return Trial(tuple(commands), reads, np.zeros(len(reads)), 0.0)


def candidates(**changes: float) -> dict[str, np.ndarray]:
    figures = assumed_figures(YAW)
    return figures_of([figures, {**figures, **changes}])


def test_a_step_asked_at_once_runs_no_faster_than_the_servo_and_a_slower_servo_is_slower():
    step = trial(SentMove(0.0, 60.0, 0.0), until_s=0.8)
    read = simulate(step, LOAD, candidates(no_load_speed_deg_s=YAW.no_load_speed_deg_s / 2))
    halfway_s = [step.read_s[np.argmax(read[:, c] > 30.0)] for c in range(2)]
    assert halfway_s[0] >= 30.0 / YAW.no_load_speed_deg_s  # 80 ms at full speed from the start
    assert halfway_s[1] > 1.7 * halfway_s[0]
    assert read[-1] == pytest.approx([60.0, 60.0], abs=0.5)


def test_the_models_step_follows_a_light_joints_quick_step_as_a_fine_one_does():
    """The base's load is mostly its servo's armature, as a wrist's or a coxa's: its quick
    steps are the fastest motion the fit sees."""
    step = trial(SentMove(0.0, 5.0, 0.0), until_s=0.6)
    figures = candidates(friction_nm=0.03, response_delay_s=0.005)
    fine = simulate(step, LOAD, figures, dt_s=0.001)
    assert np.abs(simulate(step, LOAD, figures) - fine).mean() < 0.03


def test_a_sagging_supply_slows_a_step_at_stall_as_a_weaker_servo_would():
    """Its torque and gain sag with the supply, not its back-EMF damping: at stall it runs
    as a servo that much weaker and slower."""
    step = trial(SentMove(0.0, 60.0, 0.0), until_s=0.4)
    both = candidates()
    sagging = simulate(step, LOAD, both, supply_sag_per_nm=0.1 / YAW.stall_torque_nm)[:, 0]
    weaker = candidates(
        stall_torque_nm=YAW.stall_torque_nm * 0.9,
        no_load_speed_deg_s=YAW.no_load_speed_deg_s * 0.9,
    )
    steady = simulate(step, LOAD, weaker)
    halfway = [step.read_s[np.argmax(read > 30.0)] for read in (sagging, *steady.T)]
    assert halfway[0] == pytest.approx(halfway[2], abs=0.003)
    assert halfway[0] > halfway[1] + 0.005


def test_the_supplys_sag_is_set_by_its_reads_against_the_servos_load():
    """The shoulder held upright and leaning 60° forward pushes against gravity: the supply
    reads fall with that push, by 0.3 V at stall here."""
    shoulder = actuator_params(ARM6)[1]
    load = joint_load(ARM6, "shoulder", [0.0] * 6)
    figures = assumed_figures(shoulder)
    read_s = np.array([0.9, 1.0, 2.4, 2.5, 2.6])
    leaning = abs(float(load.gravity_at(np.radians([60.0]))[0])) / shoulder.stall_torque_nm
    upright = abs(float(load.gravity_at(np.zeros(1))[0])) / shoulder.stall_torque_nm
    volts = 7.4 - 0.3 * np.where(read_s > 2, leaning, upright)
    reads = np.arange(0.0, 3.0, 0.004)
    moves = (SentMove(0.0, 0.0, 0.0), SentMove(1.2, 60.0, 0.5))
    held = Trial(moves, reads, np.zeros(len(reads)), 0.0, supply=SupplyReads(read_s, volts))
    assert leaning - upright > 0.2
    per_nm = 0.3 / 7.4 / shoulder.stall_torque_nm
    assert supply_sag(held, load, figures) == pytest.approx(per_nm, rel=0.05)
    # too few reads to draw a line through: no sag
    two = Trial(moves, reads, held.read_deg, 0.0, supply=SupplyReads(read_s[:2], volts[:2]))
    assert supply_sag(two, load, figures) == 0.0


def test_a_response_delay_starts_the_move_that_much_later():
    step = trial(SentMove(0.0, 10.0, 0.2), until_s=0.4)
    read = simulate(step, LOAD, candidates(response_delay_s=0.05))
    moving = np.abs(read) > 0.05
    first = [step.read_s[np.argmax(moving[:, c])] for c in range(2)]
    assert first[1] - first[0] == pytest.approx(0.05, abs=0.008)


def test_gear_play_swallows_a_reversal_smaller_than_itself():
    moves = trial(SentMove(0.0, 10.0, 0.3), SentMove(0.6, 8.5, 0.2), until_s=1.2)
    read = simulate(moves, LOAD, candidates(backlash_deg=2.0, deadband_deg=0.0))
    before = read[np.searchsorted(moves.read_s, 0.55)]
    after = read[-1]
    assert before[0] - after[0] > 1.0  # 0.5° of play: it comes back most of the way
    assert before[1] - after[1] == pytest.approx(0.0, abs=0.05)  # 2°: it does not move


def test_gravity_makes_a_loaded_joint_sag_by_its_torque_over_the_gain():
    shoulder = actuator_params(ARM6)[1]
    load = joint_load(ARM6, "shoulder", [0.0] * 6)
    hold = Trial((SentMove(0.0, 60.0, 0.5),), np.arange(0.0, 2.0, 0.002), np.zeros(1000), 0.0)
    figures = assumed_figures(shoulder)
    read = simulate(
        hold, load, figures_of([figures, {**figures, "kp_nm_rad": figures["kp_nm_rad"] / 2}])
    )
    sag = read[-1] - 60.0
    gravity = float(load.gravity_at(np.radians([read[-1, 0]]))[0])
    assert gravity > 0.1  # the arm leans forward, gravity pulls it on
    assert sag[1] > 1.8 * sag[0] > 0


ELBOW = joint_load(ARM6, "elbow", [0.0] * 6)


def test_the_elbow_with_its_neighbours_yielding_steps_as_in_mujoco():
    """The elbow 20° forward in 60 ms and back in MuJoCo: the shoulder gives way 3-4° under it,
    the wrist_pitch ~1°. With them read (in whole read units, every 8 ms) the joint model
    follows MuJoCo's elbow; on a rigid base it strays over ten times as far."""
    moves = (SentMove(0.3, 20.0, 0.06), SentMove(1.0, 5.0, 0.05))
    trace = arm6_stepped_in_mujoco("elbow", moves, until_s=1.6)
    times = np.arange(1, len(trace) + 1) * 0.002
    neighbours = tuple(
        NeighbourReads(name, times[3::4], np.round(trace[3::4, column] / 0.24) * 0.24, 0.0)
        for name, column in (("shoulder", 1), ("wrist_pitch", 3))
    )
    read = Trial(moves, times[1::2], trace[1::2, 2], 0.0, neighbours)
    figures = figures_of([assumed_figures(actuator_params(ARM6)[2])])
    yielding = simulate(read, ELBOW, figures)[:, 0]
    rigid = simulate(dataclasses.replace(read, neighbours=()), ELBOW, figures)[:, 0]
    assert np.abs(yielding - read.read_deg).mean() < 0.04
    assert np.abs(rigid - read.read_deg).mean() > 10 * np.abs(yielding - read.read_deg).mean()


def held_by_friction_in_mujoco(joint: str, friction_nm: float, torque_nm: float) -> Trial:
    """arm6 upright in MuJoCo (1 s, its 2 ms step), ``joint``'s servo off, its dry friction
    ``friction_nm`` against ``torque_nm`` (gravity and a push), the others held by their
    servos: the joint's and its neighbours' positions at every step, as reads."""
    model = load_model(ARM6)
    index = index_joints(model, ARM6)
    j = ARM6.joint_names.index(joint)
    params = actuator_params(ARM6, {joint: {"friction_nm": friction_nm}})
    apply_servo_models(model, index, params, ARM6)
    data = start_state(model, index, np.zeros(6))
    gravity = float(joint_load(ARM6, joint, [0.0] * 6).gravity_at(np.zeros(1))[0])
    trace = np.empty((500, 6))
    for step in range(len(trace)):
        data.ctrl[index.actuator] = 0.0
        data.ctrl[index.actuator[j]] = data.qpos[index.qpos[j]]  # no torque
        data.qfrc_applied[index.dof[j]] = torque_nm - gravity
        mujoco.mj_step(model, data)
        trace[step] = np.degrees(data.qpos[index.qpos])
    times = np.arange(1, len(trace) + 1) * model.opt.timestep
    neighbours = tuple(
        NeighbourReads(n, times, trace[:, ARM6.joint_names.index(n)], 0.0)
        for n in ("shoulder", "elbow", "wrist_pitch")
        if n != joint
    )
    return Trial((Unload(0.0),), times, trace[:, j], 0.0, neighbours)


@pytest.mark.parametrize("joint", ["elbow", "wrist_pitch"])
def test_a_joint_held_by_dry_friction_creeps_on_as_in_mujoco(joint):
    """MuJoCo's dry friction is a soft constraint: held below its limit, a joint creeps on, a
    heavy joint (the elbow, its inertia 1.5 times what MuJoCo weighs its friction by) as a
    light one (the wrist_pitch)."""
    friction, torque = 0.03, 0.02
    held = held_by_friction_in_mujoco(joint, friction, torque)
    load = joint_load(ARM6, joint, [0.0] * 6)
    # gravity as it changes with the angle, plus the push that makes it ``torque`` at 0
    pushed = dataclasses.replace(
        load, gravity_nm=load.gravity_nm - load.gravity_at(np.zeros(1)) + torque
    )
    figures = assumed_figures(actuator_params(ARM6)[ARM6.joint_names.index(joint)])
    read = simulate(held, pushed, figures_of([{**figures, "friction_nm": friction}]))[:, 0]
    assert held.read_deg[-1] > 0.1  # half a read unit in a second
    assert read[-1] == pytest.approx(held.read_deg[-1], rel=0.02)
    assert np.abs(read - held.read_deg).max() < 0.005
