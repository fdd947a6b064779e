"""The emulated bus that is the physics (``sim://?physics=ROBOT``): the preview's MuJoCo robot
behind emulated servos, in virtual time."""

from __future__ import annotations

import numpy as np
import pytest
import serial

from choreo.bus.servo_bus import ServoBus
from choreo.bus.settings import BusSettings
from choreo.core.clock import RealClock, VirtualClock
from choreo.emulator import register_url_handler
from choreo.errors import SourceError
from choreo.play.play_motion import play_motion
from choreo.preview import twin as twin_module
from choreo.preview.pipeline import simulate_motion
from choreo.preview.twin import THERMAL_TIME_S, PhysicsTwin
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
SHOULDER = 2  # servo ID: pitches the whole arm forward


def open_twin(query: str = "") -> tuple[ServoBus, PhysicsTwin]:
    bus = ServoBus.from_settings(BusSettings(port=f"sim://?physics=arm6{query}"))
    return bus, bus.emulator.physics  # type: ignore[union-attr]


def wait(bus: ServoBus, seconds: float) -> None:
    bus.clock.sleep_until(bus.clock.now() + seconds)


def real_deg(bus: ServoBus, twin: PhysicsTwin) -> np.ndarray:
    """Where the joints really are now, once the bus has delivered what was sent."""
    bus.emulator.catch_up()  # type: ignore[union-attr]
    return twin.position_deg(bus.clock.now())


def units(angle_deg: float, servo_id: int = SHOULDER) -> int:
    joint = next(j for j in ARM6.joints if j.servo_id == servo_id)
    return round(joint.to_units(angle_deg))


def test_playing_a_motion_on_the_physics_does_what_the_preview_predicts():
    """One model: the same ticks through the player, the wire and the emulated servos move the
    joints as the preview's rollout says, within a tenth of a degree or two."""
    preview = simulate_motion("motions/arm6/wave.yaml").rollout
    bus, twin = open_twin()
    with bus:
        report = play_motion("motions/arm6/wave.yaml", bus, on_note=lambda note: None)
        first_start_s = bus.emulator.log.moves[0].time_s  # type: ignore[union-attr]
    assert report.outcome.value == "completed"
    times = np.array([step.time_s for step in twin.trace])
    played = np.array([step.position_deg for step in twin.trace])
    at = first_start_s + preview.times_s - preview.approach_start_s
    keep = (preview.times_s >= preview.approach_start_s) & (at <= times[-1])
    on_bus = np.column_stack([np.interp(at[keep], times, played[:, j]) for j in range(6)])
    predicted = preview.position_deg[keep]
    assert np.ptp(predicted, axis=0).max() > 40  # it does wave
    assert np.abs(on_bus - predicted).max() < 0.3


def test_a_loaded_joint_reads_where_it_really_is():
    """The shoulder held 60° forward sags past its target under the arm's weight, and says so."""
    bus, twin = open_twin()
    with bus:
        bus.move(SHOULDER, units(60), 500)
        wait(bus, 1.0)
        read = ARM6.joints[1].to_deg(bus.read_position(SHOULDER))
        real = real_deg(bus, twin)[1]
    assert real > 60.5  # the arm's weight pulls it on
    assert read == pytest.approx(real, abs=0.24)  # to the count


def test_the_supply_sags_under_load_and_a_servo_warms_holding_it():
    bus, twin = open_twin()
    with bus:
        wait(bus, 1.0)
        idle_mv, cool_c = bus.read_vin(SHOULDER), bus.read_temperature(SHOULDER)
        bus.move(SHOULDER, units(80), 800)  # the arm nearly straight out (90° is its stop)
        wait(bus, 2.0)
        loaded_mv = bus.read_vin(SHOULDER)
        # a third of the thermal time constant (THERMAL_TIME_S): the shoulder is 2.5 °C warmer
        # (5.4 after the whole of it), which the servo reads in whole degrees
        wait(bus, THERMAL_TIME_S / 3)
        warm_c, yaw_c = bus.read_temperature(SHOULDER), bus.read_temperature(1)
    assert loaded_mv < idle_mv - 20
    assert warm_c >= cool_c + 2
    assert yaw_c == cool_c  # the base carries no torque: it stays cool


def test_torque_off_lets_a_joint_fall_and_a_load_holds_it_where_it_fell():
    bus, twin = open_twin()
    with bus:
        bus.move(SHOULDER, units(45), 500)
        wait(bus, 1.0)
        before = bus.read_position(SHOULDER)
        bus.unload(SHOULDER)
        wait(bus, 0.3)
        bus.load(SHOULDER)
        fallen = bus.read_position(SHOULDER)
        wait(bus, 1.0)
        held = bus.read_position(SHOULDER)
        wait(bus, 1.0)
        still = bus.read_position(SHOULDER)
    assert ARM6.joints[1].to_deg(fallen) > ARM6.joints[1].to_deg(before) + 10
    assert abs(held - fallen) <= 10  # caught as it fell (it was moving: a little overshoot)
    assert abs(still - held) <= 1


def test_a_truth_file_makes_the_servos_differ_from_the_robot_files(tmp_path):
    """Weaker, late and offset servos: the shoulder sags more, starts later, and stands where the
    horn's offset puts it while reading what it was asked."""
    truth = tmp_path / "truth.yaml"
    truth.write_text(
        "supply: {voltage_v: 7.0, resistance_ohm: 0.3}\n"
        "servos:\n"
        "  2: {stall_torque_nm: 0.8, kp_nm_rad: 6.0, response_delay_s: 0.05}\n"
        "joints:\n"
        "  base_yaw: {offset_deg: 3.0}\n"
    )
    sags = {}
    for name, query in (("assumed", ""), ("truth", f"&truth={truth}")):
        bus, twin = open_twin(query)
        with bus:
            bus.move(SHOULDER, units(60), 200)
            bus.move(1, units(20, servo_id=1), 200)
            wait(bus, 0.03)
            moved_at_30ms = real_deg(bus, twin)[1]
            wait(bus, 1.0)
            sags[name] = real_deg(bus, twin)[1] - 60
            real_yaw = real_deg(bus, twin)[0]
            read_yaw = ARM6.joints[0].to_deg(bus.read_position(1))
        if name == "truth":
            assert moved_at_30ms == pytest.approx(0.0, abs=0.05)  # 50 ms late: not yet going
            assert real_yaw == pytest.approx(23.0, abs=0.5)
            assert twin.supply_v == 7.0
        else:
            assert moved_at_30ms > 1.0
            assert real_yaw == pytest.approx(20.0, abs=0.5)
        assert read_yaw == pytest.approx(20.0, abs=0.5)
    assert sags["truth"] > 2 * sags["assumed"] > 0


def test_a_servo_caps_its_own_moves_at_its_speed_in_the_truth_file(tmp_path):
    """As the preview's servos do: a servo slower than the datasheet's sets its own pace."""
    truth = tmp_path / "truth.yaml"
    truth.write_text("joints:\n  base_yaw: {no_load_speed_deg_s: 150.0}\n")
    bus, twin = open_twin(f"&truth={truth}")
    with bus:
        servos = bus.emulator.servos  # type: ignore[union-attr]
        assert twin.actuators[0].no_load_speed_deg_s == pytest.approx(150.0, rel=0.05)
        assert servos[0].model.no_load_speed_deg_s == twin.actuators[0].no_load_speed_deg_s
        assert servos[1].model.no_load_speed_deg_s == twin.actuators[1].no_load_speed_deg_s
        assert servos[1].model.no_load_speed_deg_s > 300.0  # the others' as assumed


def test_gear_play_and_dead_band_are_seen_in_small_reversals(tmp_path):
    """The base (no gravity load) with 2° of play: a 1.5° reversal is taken up by the play, and
    the output does not move; with the robot file's 0.5° it does."""
    truth = tmp_path / "truth.yaml"
    truth.write_text("joints:\n  base_yaw: {backlash_deg: 2.0, deadband_deg: 0.0}\n")
    moved = {}
    for name, query in (("assumed", ""), ("truth", f"&truth={truth}")):
        bus, twin = open_twin(query)
        with bus:
            bus.move(1, units(10, servo_id=1), 300)
            wait(bus, 0.6)
            there = real_deg(bus, twin)[0]
            bus.move(1, units(8.5, servo_id=1), 300)
            wait(bus, 0.6)
            moved[name] = there - real_deg(bus, twin)[0]
    assert moved["truth"] == pytest.approx(0.0, abs=0.05)
    assert moved["assumed"] > 0.8


def test_the_trace_keeps_the_last_steps_each_with_its_time_and_position(monkeypatch):
    monkeypatch.setattr(twin_module, "TRACE_LIMIT", 250)
    monkeypatch.setattr(twin_module, "STEPS_AT_ONCE", 100)  # a wait of stretches: the odd one cut
    bus, twin = open_twin()
    with bus:
        bus.move(SHOULDER, units(30), 300)
        wait(bus, 0.7)  # 350 steps of 2 ms
        now_deg = real_deg(bus, twin)
        now_s = bus.clock.now()
    trace = twin.trace
    assert len(trace) == 250
    np.testing.assert_allclose(np.diff([step.time_s for step in trace]), twin.dt_s)
    assert trace[-1].time_s == pytest.approx(now_s, abs=twin.dt_s)
    np.testing.assert_array_equal(trace[-1].position_deg, now_deg)
    assert trace[0].position_deg[1] < trace[-1].position_deg[1] - 10  # the shoulder on its way
    assert all(step.supply_v < twin.supply_v for step in trace)  # the servos draw current


def test_time_is_virtual_unless_asked_for():
    bus, _ = open_twin()
    with bus:
        assert isinstance(bus.clock, VirtualClock)
    bus, _ = open_twin("&clock=real")
    with bus:
        assert isinstance(bus.clock, RealClock)


@pytest.mark.parametrize(
    "query, message",
    [
        ("physics=arm6&ids=1-6", "leave out ids="),
        ("truth=x.yaml", "truth= goes with a robot's physics"),
        ("physics=hexapod18&stand=yes", "stand must be 0 or 1"),
    ],
)
def test_url_options_that_do_not_go_with_physics_are_refused(query, message):
    register_url_handler()
    with pytest.raises(serial.SerialException, match=message):
        serial.serial_for_url(f"sim://?{query}")


def test_a_bad_truth_file_is_told_at_its_line(tmp_path):
    truth = tmp_path / "truth.yaml"
    truth.write_text("joints:\n  elbow: {backlash_deg: -1}\n")
    with pytest.raises(SourceError, match=r"truth.yaml:2:\d+: joints: elbow: backlash_deg"):
        open_twin(f"&truth={truth}")


def test_on_a_stand_a_walker_is_held_in_the_air_and_its_legs_move_freely():
    bus = ServoBus.from_settings(BusSettings(port="sim://?physics=hexapod18&stand=1"))
    twin: PhysicsTwin = bus.emulator.physics  # type: ignore[union-attr]
    with bus:
        body = twin._data.xpos[1].copy()  # the torso, the first body after the world
        joint = twin.robot.joints[1]  # a leg's femur (30° at home): it lifts the leg
        bus.move(joint.servo_id, round(joint.to_units(60.0)), 300)
        wait(bus, 1.0)
        assert real_deg(bus, twin)[1] == pytest.approx(60.0, abs=1.5)
        assert twin._data.xpos[1] == pytest.approx(body)  # the body has not moved
        assert body[2] > 0.1  # held up: the feet are off the floor


def test_on_a_stand_every_joint_stands_at_home_and_a_coxa_beside_the_body_turns():
    """Fixed in the air, the body is part of the world, whose contacts with its children MuJoCo
    does not filter: the stand excludes them, or lf_coxa, touching the body, is pushed to -45°."""
    bus = ServoBus.from_settings(BusSettings(port="sim://?physics=hexapod18&stand=1"))
    twin: PhysicsTwin = bus.emulator.physics  # type: ignore[union-attr]
    home = np.array(twin.robot.pose_vector("home"))
    with bus:
        wait(bus, 0.5)
        assert real_deg(bus, twin) == pytest.approx(home, abs=1.0)
        coxa = twin.robot.joint("lf_coxa")
        bus.move(coxa.servo_id, round(coxa.to_units(15.0)), 300)
        wait(bus, 1.0)
        assert real_deg(bus, twin)[0] == pytest.approx(15.0, abs=1.0)
