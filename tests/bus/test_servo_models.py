"""choreo.bus.servo_models: the datasheet table. Golden values are the vendor's figures as tabled
in docs/servo-models.md (kg·cm at the rated supply, seconds per 60°), converted here by hand."""

from __future__ import annotations

import math

import pytest

from choreo.bus.servo_models import DEG_PER_UNIT, SERVO_MODELS, UNITS_PER_DEG, servo_model

KG_CM_NM = 0.0981  # 1 kg·cm in N·m (servo-models.md)

# model: (stall kg·cm, s per 60° no-load, rated supply V, supply range mV) from servo-models.md
DATASHEET = {
    "LX-16A": (17, 0.16, 7.4, (6000, 8400)),
    "LX-224HV": (20, 0.19, 11.1, (9000, 12600)),  # 0.18-0.20 s/60°: the middle
    "LX-824HV": (17, 0.20, 11.1, (9000, 12600)),
    "HTD-35H": (35, 0.18, 11.1, (9000, 12600)),
}


def test_positions_are_0_to_1000_over_240_degrees():
    assert DEG_PER_UNIT == pytest.approx(0.24)
    assert 1000 * DEG_PER_UNIT == pytest.approx(240) and UNITS_PER_DEG * DEG_PER_UNIT == 1


@pytest.mark.parametrize("name", DATASHEET)
def test_each_model_carries_its_datasheet_figures(name):
    stall_kg_cm, s_per_60, rated_v, supply_mv = DATASHEET[name]
    model = servo_model(name)
    assert model.stall_torque_nm == pytest.approx(stall_kg_cm * KG_CM_NM)
    assert model.no_load_speed_deg_s == pytest.approx(60 / s_per_60)
    assert model.rated_supply_v == rated_v
    assert model.vin_range_mv == supply_mv


def test_the_lx16a_derived_defaults_are_the_documented_ones():
    """servo-models.md: planning at 300°/s, damping 0.255 N·m·s/rad, kp about 16 N·m/rad."""
    lx16a = servo_model("LX-16A")
    assert lx16a.vel_limit_deg_s == pytest.approx(300)
    assert lx16a.damping_nm_s_rad == pytest.approx(0.255, abs=0.001)
    assert lx16a.kp_nm_rad == pytest.approx(16, abs=0.5)
    assert math.degrees(lx16a.stall_torque_nm / lx16a.kp_nm_rad) == pytest.approx(6, abs=0.1)
    assert (lx16a.acc_limit_deg_s2, lx16a.jerk_limit_deg_s3) == (3000, 30000)


def test_only_the_lx16a_leaves_wait_read_and_dis_read_unanswered():
    """servo-models.md: "cmd 8 and 48 not answered" on the LX-16A alone."""
    silent = {n for n, m in SERVO_MODELS.items() if not (m.answers_wait_read or m.answers_dis_read)}
    assert silent == {"LX-16A"}


def test_unconfirmed_models_are_treated_as_the_lx224hv():
    reference = servo_model("LX-224HV")
    for name in ("LX-224", "LX-225", "LX-15D"):
        model = servo_model(name)
        assert (model.stall_torque_nm, model.no_load_speed_deg_s, model.vin_range_mv) == (
            reference.stall_torque_nm,
            reference.no_load_speed_deg_s,
            reference.vin_range_mv,
        )


def test_an_unknown_model_lists_the_known_ones():
    with pytest.raises(ValueError) as raised:
        servo_model("LX-16")
    assert str(raised.value) == (
        "unknown servo model 'LX-16'; known models: LX-16A, LX-224HV, LX-824HV, HTD-35H, "
        "LX-224, LX-225, LX-15D"
    )
