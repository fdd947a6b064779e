"""What the legs on the floor must hold up, against the servos' stall torque at the supply: a
gait too heavy for them is told at its gait: line, whatever its period."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from paths import REPO

from choreo.bus.servo_models import servo_model
from choreo.errors import SourceError
from choreo.motion.gait import Gait, Pattern, gait_keyframes
from choreo.motion.motion_file import load_motion
from choreo.motion.stance_load import (
    GRAVITY_M_S2,
    holding_torques_nm,
    stall_torque_nm,
    worst_overload,
)
from choreo.robot.kinematics import Kinematics, SiteGoal
from choreo.robot.robot_file import load_robot

HEXAPOD = load_robot("hexapod18", with_figures=False)
KIN = Kinematics(HEXAPOD)
FEET = KIN.feet()
MASS_KG = float(KIN.model.body_mass.sum())
HOME = np.array(HEXAPOD.pose_vector("home"))
FEMURS = [j for j, name in enumerate(HEXAPOD.joint_names) if name.endswith("_femur")]


def tripod_stance() -> np.ndarray:
    """hexapod18 with one tripod (lf, rm, lr) lifted 30 mm, the other three down."""
    home_feet = np.array([KIN.site_pose(foot, HOME).position_mm for foot in FEET])
    swing = gait_keyframes(home_feet, Gait(Pattern.TRIPOD, 1, stride_mm=0.0, lift_mm=30))[1]
    goals = [SiteGoal(foot, tuple(p)) for foot, p in zip(FEET, swing.feet_mm)]
    solution = KIN.solve(goals, HOME, np.ones(len(HOME), bool))
    assert solution.ok
    return solution.angles_deg


def test_six_feet_share_the_weight_and_three_carry_it_all():
    six, down = holding_torques_nm(KIN, FEET, HOME, MASS_KG)
    assert down == 6
    assert six[FEMURS] == pytest.approx([six[FEMURS[0]]] * 6, rel=1e-3)  # the stance is even
    # a share of the 2.55 kg on each foot, ~100 mm out from its femur (the robot file's
    # figures: 0.4 N·m on six feet)
    assert (
        MASS_KG * GRAVITY_M_S2 / 6 * 0.09 < abs(six[FEMURS[0]]) < MASS_KG * GRAVITY_M_S2 / 6 * 0.12
    )
    three, down = holding_torques_nm(KIN, FEET, tripod_stance(), MASS_KG)
    assert down == 3
    carrying = [j for j in FEMURS if abs(three[j]) > 0.01]
    assert len(carrying) == 3
    # the three carry the weight six did: twice as much each, on average; the middle foot,
    # alone on its side, half of it
    total = np.abs(three[carrying]).sum()
    assert total == pytest.approx(2 * np.abs(six[carrying]).sum(), rel=0.05)
    alone = HEXAPOD.joint_names.index("lm_femur")
    assert alone in carrying and abs(three[alone]) == pytest.approx(max(np.abs(three)))


def test_the_stall_torque_is_at_the_declared_supply_and_a_measured_figure_counts():
    femur = HEXAPOD.joint("lf_femur")
    model = servo_model(femur.servo_model)
    assert stall_torque_nm(HEXAPOD, femur) == pytest.approx(model.stall_torque_nm)
    at_6v = replace(HEXAPOD, bus=replace(HEXAPOD.bus, supply_v=6.0))
    assert stall_torque_nm(at_6v, femur) == pytest.approx(model.stall_torque_nm * 6 / 11.1)
    weak = replace(femur, actuator={"stall_torque_nm": 0.9})
    assert stall_torque_nm(HEXAPOD, weak) == pytest.approx(0.9)
    assert worst_overload(KIN, FEET, [HOME, tripod_stance()]) is None


def hexapod_with(tmp_path: Path, defaults: str) -> Path:
    models = tmp_path / "models"
    shutil.copytree(REPO / "models" / "hexapod18", models / "hexapod18")
    robot_file = models / "hexapod18" / "robot.yaml"
    robot_file.write_text(robot_file.read_text().replace("defaults:", defaults, 1))
    return robot_file


def walk(tmp_path: Path, robot_file: Path, gait: str) -> Path:
    path = tmp_path / "walk.yaml"
    path.write_text(
        f"robot: {robot_file.as_posix()}\nkeyframes:\n  - pose: home\n  - gait: {{{gait}}}\n"
    )
    return path


@pytest.mark.parametrize(
    "defaults",
    [
        "bus:\n  supply_v: 6.0\ndefaults:",  # 6/11.1 of the LX-224HV's 1.96 N·m
        "defaults:\n  actuator: {stall_torque_nm: 1.0}",  # a weak servo (or a measured one)
    ],
)
def test_a_gait_too_heavy_for_the_servos_is_told_at_its_line_with_what_would_help(
    tmp_path, defaults
):
    robot_file = hexapod_with(tmp_path, defaults)
    tripod = walk(tmp_path, robot_file, "pattern: tripod, steps: 2, stride: 40, period: 4")
    with pytest.raises(SourceError) as caught:
        load_motion(tripod)
    (message,) = caught.value.problems
    assert message.startswith(f"{tripod}:4:5: gait: at step ")
    assert "on 3 feet, " in message and "_femur needs 1.0" in message
    assert "more than its servo's" in message and "stall torque at " in message
    assert "at any period; keep more feet down (pattern: ripple or wave)" in message
    # five feet down share the weight: the same servos carry it
    wave = walk(tmp_path, robot_file, "pattern: wave, steps: 1, stride: 40, period: 8")
    assert load_motion(wave).keyframes


@pytest.mark.parametrize(
    "gait",
    [
        Gait(Pattern.TRIPOD, 6, stride_mm=40),
        Gait(Pattern.WAVE, 6, stride_mm=30, turn_deg=5),
        Gait(Pattern.RIPPLE, 6, stride_mm=0, sideways_mm=30, turn_deg=8),
    ],
    ids=lambda gait: gait.pattern.value,
)
def test_from_the_third_step_the_feet_stand_under_the_body_as_in_the_third(gait):
    """Why a gait's stances are judged at its first three steps and its last only."""
    home_feet = np.array([KIN.site_pose(foot, HOME).position_mm for foot in FEET])
    by_step: dict[int, list[np.ndarray]] = {}
    for frame in gait_keyframes(home_feet, gait):
        by_step.setdefault(frame.step, []).append(frame.feet_mm)
    for step in range(4, gait.steps):
        assert np.array(by_step[step]) == pytest.approx(np.array(by_step[3]), abs=1e-6)
