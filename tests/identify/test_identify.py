"""``choreo identify`` on the emulated robot whose servos are the physics, with hidden truths."""

from __future__ import annotations

import sys

import pytest
import yaml
from identify_helpers import make_identify_quick

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.bus.settings import BusSettings
from choreo.errors import SourceError, UnsupportedByTransport
from choreo.identify import identify
from choreo.preview.actuator import actuator_params
from choreo.robot.robot_file import load_robot
from choreo.robot.servo_figures import read_servo_figures
from choreo.robot.types import GaitCompensation

ARM6 = load_robot("arm6")
TRUTH = {
    "deadband_deg": 0.5,
    "backlash_deg": 1.1,
    "no_load_speed_deg_s": 300.0,
    "kp_nm_rad": 12.0,
    "stall_torque_nm": 1.3,
    "friction_nm": 0.03,
    "response_delay_s": 0.012,
}


@pytest.fixture
def quick(monkeypatch):
    """Short test moves and a short search (identify_helpers.py)."""
    make_identify_quick(monkeypatch)


def twin(tmp_path, truth: dict | None = None) -> ServoBus:
    query = "physics=arm6"
    if truth is not None:
        path = tmp_path / "truth.yaml"
        path.write_text(yaml.safe_dump({"joints": truth}))
        query += f"&truth={path}"
    return ServoBus.from_settings(BusSettings(port=f"sim://?{query}"))


# The full test moves, and 30 of the search's 45 generations: ~3.5 s of CPU (2026-11-27, 13:40,
# beside other work): the emulated bus and its physics ~1.9 s for the 24 s of moves (13,000
# reads, each a physics step and a request's Python), the fit ~1.6 s (two searches side by
# side). The default search's convergence on a hidden truth is test_fit.py's (its whole fit);
# here 30 generations find this truth's figures from each of 6 seeds (the gain up to 11 % low,
# the backlash 0.04° off at worst), 20 from 5 of them.
FIT_GENERATIONS = 30


def test_the_fitted_figures_find_a_hidden_truth_and_predict_held_out_moves(tmp_path):
    with twin(tmp_path, {"elbow": TRUTH}) as bus:
        report = identify(
            ARM6, bus, tmp_path / "figures.yaml", joints=["elbow"], generations=FIT_GENERATIONS
        )
    (elbow,) = report.identified
    v = elbow.validation
    assert v.fitted_median_deg <= 0.5
    assert v.fitted_median_deg <= 0.5 * v.default_median_deg
    assert elbow.figures["backlash_deg"] == pytest.approx(TRUTH["backlash_deg"], abs=0.1)
    # the gain too, which a model of the elbow on a rigid shoulder put 27-30 % low
    for name in ("no_load_speed_deg_s", "stall_torque_nm", "kp_nm_rad"):  # (the rest: bench)
        assert elbow.figures[name] == pytest.approx(TRUTH[name], rel=0.15), name
    # the shoulder gives way under the elbow by degrees (read along and replayed in the fit)
    assert list(elbow.neighbours_moved_deg) == ["shoulder", "wrist_pitch"]
    assert elbow.neighbours_moved_deg["shoulder"] > 2.0
    assert "shoulder" in elbow.neighbours_gave_way
    # three servos back to back on a 115200-baud wire, every other read the elbow's
    assert 200 < elbow.reads_per_s < 1000
    assert elbow.own_reads_per_s == pytest.approx(elbow.reads_per_s / 2, rel=0.02)
    written = yaml.safe_load((tmp_path / "figures.yaml").read_text())
    assert written["joints"]["elbow"] == elbow.figures
    assert written["validation"]["elbow"]["fitted_median_deg"] == round(v.fitted_median_deg, 3)
    moved = written["validation"]["elbow"]["neighbours_moved_deg"]
    assert moved == {name: round(deg, 2) for name, deg in elbow.neighbours_moved_deg.items()}


def test_a_run_keeps_every_joint_done_and_goes_on_from_the_next(tmp_path, quick):
    output = tmp_path / "figures.yaml"

    def interrupt(result):
        raise KeyboardInterrupt

    with twin(tmp_path) as bus:
        with pytest.raises(KeyboardInterrupt):
            identify(ARM6, bus, output, joints=["base_yaw", "wrist_roll"], on_joint=interrupt)
        assert all(bus.read_loaded(joint.servo_id) for joint in ARM6.joints)
        stops = [p for p in bus.emulator.log.packets if p.packet.command == Command.MOVE_STOP]
        assert stops  # everything told to hold where it is
    assert list(yaml.safe_load(output.read_text())["joints"]) == ["base_yaw"]
    with twin(tmp_path) as bus:
        again = identify(ARM6, bus, output, joints=["base_yaw", "wrist_roll"])
    assert again.already == ("base_yaw",)
    assert [r.joint for r in again.identified] == ["wrist_roll"]
    assert again.gait is None  # an arm does not walk: no gait (a walker's: the test below)
    assert list(yaml.safe_load(output.read_text())["joints"]) == ["base_yaw", "wrist_roll"]


def test_a_joints_neighbours_hold_with_the_figures_measured_before_it(tmp_path, quick, monkeypatch):
    identify_module = sys.modules["choreo.identify.identify"]
    real_load = identify_module.joint_load
    neighbours_of = {}  # each joint's neighbours' servos as its fit simulates them

    def spied(robot, joint, pose, overrides=None):
        load = real_load(robot, joint, pose, overrides)
        neighbours_of[joint] = {c.joint: c.servo for c in load.neighbours}
        return load

    monkeypatch.setattr(identify_module, "joint_load", spied)
    assumed = dict(zip(ARM6.joint_names, actuator_params(ARM6)))
    output = tmp_path / "figures.yaml"
    with twin(tmp_path) as bus:
        report = identify(ARM6, bus, output, joints=["shoulder", "elbow"])
    shoulder = report.identified[0].figures
    assert shoulder["kp_nm_rad"] != pytest.approx(assumed["shoulder"].kp_nm_rad)
    assert neighbours_of["shoulder"]["elbow"] == assumed["elbow"]  # not measured yet
    held_by = neighbours_of["elbow"]["shoulder"]
    for name in ("kp_nm_rad", "stall_torque_nm", "deadband_deg", "no_load_speed_deg_s"):
        assert getattr(held_by, name) == pytest.approx(shoulder[name])
    assert neighbours_of["elbow"]["wrist_pitch"] == assumed["wrist_pitch"]
    # a later run takes them from the file the earlier one wrote
    elbow = report.identified[1].figures
    with twin(tmp_path) as bus:
        identify(ARM6, bus, output, joints=["wrist_pitch"])
    assert neighbours_of["wrist_pitch"]["elbow"].kp_nm_rad == pytest.approx(elbow["kp_nm_rad"])


def test_a_board_that_cannot_read_positions_is_refused_before_anything_moves(tmp_path):
    with ServoBus.from_settings(
        BusSettings(port="sim://?board=lobot&ids=1-6&clock=virtual")
    ) as bus:
        with pytest.raises(UnsupportedByTransport, match="cannot read a servo's supply voltage"):
            identify(ARM6, bus, tmp_path / "figures.yaml")
        assert not bus.emulator.log.moves
    assert not (tmp_path / "figures.yaml").exists()


def test_unknown_joints_are_refused_naming_the_valid_ones(tmp_path):
    with (
        twin(tmp_path) as bus,
        pytest.raises(ValueError, match="no such joint; its joints: base_yaw"),
    ):
        identify(ARM6, bus, tmp_path / "f.yaml", joints=["knee"])


def test_a_walkers_gait_is_recalibrated_with_the_measured_figures_and_kept_in_the_file(
    tmp_path, quick, monkeypatch
):
    """The calibration itself is tested in tests/preview/test_gait_calibration.py."""
    seen = []

    def calibrated(robot):
        seen.append(robot)
        return GaitCompensation(8.0, 1.09, 1.15)

    monkeypatch.setattr(sys.modules["choreo.identify.identify"], "calibrated_gait", calibrated)
    hexapod = load_robot("hexapod18", with_figures=False)
    output = tmp_path / "figures.yaml"
    port = "sim://?physics=hexapod18&stand=1"
    with ServoBus.from_settings(BusSettings(port=port)) as bus:
        report = identify(hexapod, bus, output, joints=["lf_femur"])
    (femur,) = report.identified
    (measured,) = seen
    assert dict(measured.joint("lf_femur").actuator) == femur.figures
    assert report.gait == GaitCompensation(8.0, 1.09, 1.15)
    assert read_servo_figures(output, hexapod).gait == report.gait
    assert output.read_text().startswith("# hexapod18's servos as `choreo identify` measured")


def test_a_walker_too_heavy_for_its_measured_servos_keeps_no_gait_and_says_why(
    tmp_path, quick, monkeypatch
):
    def too_heavy(robot):
        raise SourceError("walk: gait: lm_femur needs 1.07 N·m, more than its 0.9 N·m")

    monkeypatch.setattr(sys.modules["choreo.identify.identify"], "calibrated_gait", too_heavy)
    hexapod = load_robot("hexapod18", with_figures=False)
    output = tmp_path / "figures.yaml"
    output.write_text("joints: {}\ngait: {lift_sag: 7, stride_scale: 1.06, turn_scale: 1.16}\n")
    with ServoBus.from_settings(BusSettings(port="sim://?physics=hexapod18&stand=1")) as bus:
        report = identify(hexapod, bus, output, joints=["lf_tibia"])
    assert report.gait is None
    assert report.gait_problem == "walk: gait: lm_femur needs 1.07 N·m, more than its 0.9 N·m"
    written = read_servo_figures(output, hexapod)
    assert written.gait is None  # the earlier one was for other figures
    assert list(written.joints) == ["lf_tibia"]
