"""choreo identify made quick for tests of what surrounds the moves and the fit: two short moves
and a two-generation search (the moves and the fit are judged in their own tests)."""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from choreo.identify import fit
from choreo.identify.joint_model import SentMove
from choreo.identify.moves import MovePlan
from choreo.preview.actuator import ServoDrive, actuator_params
from choreo.preview.model import apply_servo_models, index_joints, load_model
from choreo.preview.start import start_state
from choreo.robot.robot_file import load_robot


def make_identify_quick(monkeypatch) -> None:
    identify_module = sys.modules[
        "choreo.identify.identify"
    ]  # (the package's name is the function)
    monkeypatch.setattr(fit, "GENERATIONS", 2)

    def short(joint, pose_deg, drop=False, loaded=()):
        return MovePlan((SentMove(0.0, pose_deg + 2.0, 0.2), SentMove(0.5, pose_deg, 0.2)), 0.9)

    monkeypatch.setattr(identify_module, "fit_moves", short)
    monkeypatch.setattr(identify_module, "held_out_moves", short)


def arm6_stepped_in_mujoco(joint: str, moves: tuple[SentMove, ...], until_s: float) -> np.ndarray:
    """arm6 upright in MuJoCo (its 2 ms step), ``joint``'s servo running ``moves`` (each a
    linear move of its set-point, none faster than the servo), every other servo holding at 0,
    each by the preview's servo law (dead band, play, gain up to its stall torque): every
    joint's angle after each step, (steps, 6) degrees."""
    robot = load_robot("arm6")
    model = load_model(robot)
    index = index_joints(model, robot)
    params = actuator_params(robot)
    apply_servo_models(model, index, params, robot)
    data = start_state(model, index, np.zeros(6))
    drive = ServoDrive(params, model.opt.timestep, np.zeros(6))
    j = robot.joint_names.index(joint)
    trace = np.empty((int(round(until_s / model.opt.timestep)), 6))
    setpoint_rad = np.zeros(6)
    for step in range(len(trace)):
        setpoint_rad[j] = np.radians(_setpoint_deg(moves, step * model.opt.timestep))
        data.ctrl[index.actuator] = drive.ctrl(setpoint_rad, data.qpos[index.qpos])
        mujoco.mj_step(model, data)
        trace[step] = np.degrees(data.qpos[index.qpos])
    return trace


def _setpoint_deg(moves: tuple[SentMove, ...], at_s: float) -> float:
    where = 0.0
    for move in moves:
        if at_s < move.at_s:
            break
        where += (move.target_deg - where) * min((at_s - move.at_s) / move.time_s, 1.0)
    return where
