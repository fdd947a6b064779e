"""A walker's gait compensation found in the preview from its servos' figures: the assumed
figures give the numbers hexapod18's robot file was tuned to by hand, slower and softer servos
more, and with those the emulated "real" robot walks as the preview predicts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from choreo.bus.servo_bus import ServoBus
from choreo.bus.servo_models import servo_model
from choreo.bus.settings import BusSettings
from choreo.play.play_motion import play_motion
from choreo.preview import gait_calibration
from choreo.preview.gait_calibration import (
    FORWARD,
    calibrated_gait,
    calibration_motion,
    walks,
)
from choreo.preview.pipeline import simulate_motion
from choreo.robot.robot_file import load_robot, with_servo_figures
from choreo.robot.servo_figures import read_servo_figures
from choreo.robot.types import GaitCompensation

HEXAPOD = load_robot("hexapod18", with_figures=False)
LX_224HV = servo_model("LX-224HV")
# every servo 25 % slower, with 60 % of the gain and 80 % of the torque (worn, or a weak batch)
SLOWER_SOFTER = {
    "no_load_speed_deg_s": round(0.75 * LX_224HV.no_load_speed_deg_s, 1),
    "kp_nm_rad": round(0.6 * LX_224HV.kp_nm_rad, 2),
    "stall_torque_nm": round(0.8 * LX_224HV.stall_torque_nm, 3),
}


@pytest.fixture(scope="module")
def assumed() -> GaitCompensation:
    """hexapod18 calibrated with the servo table's figures (~4 s of CPU, once)."""
    return calibrated_gait(HEXAPOD)


def test_the_assumed_figures_give_the_numbers_the_robot_file_was_tuned_to(assumed):
    tuned = HEXAPOD.gait  # by hand, over the shipped six-step walks: 7 mm, 1.06, 1.16
    assert assumed.stride_scale == pytest.approx(tuned.stride_scale, abs=0.02)
    # the hand-tuned turn and lift were rounded up (turn_in_place turned 102 %, the feet rose
    # 101-103 %): the calibration's are a little under, never over
    assert tuned.turn_scale - 0.05 <= assumed.turn_scale <= tuned.turn_scale
    assert tuned.lift_sag_mm - 1.5 <= assumed.lift_sag_mm <= tuned.lift_sag_mm


def test_slower_softer_servos_get_more_and_the_emulated_robot_walks_as_predicted(assumed, tmp_path):
    truth = tmp_path / "truth.yaml"
    truth.write_text(yaml.safe_dump({"joints": {j.name: SLOWER_SOFTER for j in HEXAPOD.joints}}))
    measured = with_servo_figures(HEXAPOD, read_servo_figures(truth, HEXAPOD))
    own = calibrated_gait(measured)
    assert own.lift_sag_mm > assumed.lift_sag_mm + 2  # they sag more under the body
    assert own.stride_scale > assumed.stride_scale
    assert own.turn_scale > assumed.turn_scale

    def forward(by: GaitCompensation):
        return calibration_motion(dataclasses.replace(measured, gait=by), (FORWARD,))

    predicted = simulate_motion(forward(own))
    (outcome,) = predicted.gaits
    asked_mm = FORWARD.steps * FORWARD.stride_mm
    with ServoBus.from_settings(BusSettings(port=f"sim://?physics=hexapod18&truth={truth}")) as bus:
        world = bus.emulator.physics  # type: ignore[union-attr]
        start = world.body_position_m(bus.clock.now())
        play_motion(forward(own), bus, on_note=lambda note: None)
        end = world.body_position_m(bus.clock.now() + 0.5)  # settled
        real_mm = float(np.linalg.norm(end[:2] - start[:2])) * 1000
    assert predicted.travel is not None
    assert predicted.travel.displacement_mm == pytest.approx(real_mm, rel=0.03)
    assert real_mm == pytest.approx(asked_mm, rel=0.05)
    # the compensation tuned to the assumed servos leaves these short of what was asked
    (short,) = simulate_motion(forward(assumed)).gaits
    assert outcome.lift_fraction is not None and short.lift_fraction is not None
    assert abs(1 - outcome.lift_fraction) < abs(1 - short.lift_fraction)
    assert short.lift_fraction < 0.95


def test_a_calibration_is_remembered_under_the_figures_it_was_found_with(monkeypatch):
    found = []

    def calibrate(robot):
        found.append(robot)
        return GaitCompensation(5.0, 1.1, 1.2)

    monkeypatch.setattr(gait_calibration, "_calibrate", calibrate)

    def with_gain(kp_nm_rad: float):
        first = dataclasses.replace(
            HEXAPOD.joints[0], actuator={**HEXAPOD.joints[0].actuator, "kp_nm_rad": kp_nm_rad}
        )
        return dataclasses.replace(HEXAPOD, joints=(first, *HEXAPOD.joints[1:]))

    assert calibrated_gait(with_gain(9.0)) == GaitCompensation(5.0, 1.1, 1.2)
    assert calibrated_gait(with_gain(9.0)) == GaitCompensation(5.0, 1.1, 1.2)
    assert len(found) == 1  # the second from the cache
    calibrated_gait(with_gain(9.5))
    assert len(found) == 2  # another figure: found again
    six_volts = dataclasses.replace(HEXAPOD.bus, supply_v=6.0)
    calibrated_gait(dataclasses.replace(with_gain(9.0), bus=six_volts))
    assert len(found) == 3  # another supply: found again


def test_only_six_legged_walkers_are_calibrated():
    assert walks(HEXAPOD)
    assert not walks(load_robot("arm6", with_figures=False))
    assert not walks(load_robot("tonypi", with_figures=False))
