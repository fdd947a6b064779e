"""choreo.play.preflight: nothing moves until every servo answers and is fit to; every problem
is said at once, by joint."""

from __future__ import annotations

import pytest
from emulated import home_specs
from play_helpers import MOTIONS, Rig

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.emulator import BusEmulator, ServoSpec, connection
from choreo.errors import ChoreoError


def test_missing_servo_is_refused_by_name_before_anything_moves():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml", skip_ids=(3,))
    with pytest.raises(ChoreoError, match=r"1 servo\(s\) did not answer: elbow \(ID 3\)"):
        rig.play()
    assert not rig.emulator.log.moves


def test_servo_limits_narrower_than_the_robot_file_are_refused():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.bus.set_angle_limits(1, 300, 700)
    with pytest.raises(
        ChoreoError,
        match=r"base_yaw \(ID 1\): the servo's own angle limits 300..700 "
        r"are narrower than the robot file's 0..1000",
    ):
        rig.play()


def test_low_voltage_and_heat_are_refused_in_preflight():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.emulator.servo(2).vin_mv = 4000
    rig.emulator.servo(5).temperature_c = 90
    with pytest.raises(ChoreoError) as error:
        rig.play()
    assert "shoulder (ID 2): supply 4000 mV is outside" in str(error.value)
    assert "wrist_roll (ID 5): 90 °C is at or above the servo's limit 85 °C" in str(error.value)


def test_a_supply_outside_the_robot_files_servo_model_is_refused_in_preflight():
    # arm6 is LX-16A (rated 6-8.4 V, docs/servo-models.md); its stored limits are 4.5-14 V
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    assert rig.robot.joints[0].servo_model == "LX-16A"
    for servo in rig.emulator.servos:
        servo.vin_mv = 10800  # an 11.1 V (3S) pack
    with pytest.raises(ChoreoError) as error:
        rig.play()
    message = str(error.value)
    # one problem shared by every servo is one line naming them all, not one line each
    every = ", ".join(f"{j.name} (ID {j.servo_id})" for j in rig.robot.joints)
    assert f"{every}: supply 10.8 V is outside the LX-16A's rated 6-8.4 V" in message
    assert message.count("rated 6-8.4 V") == 1
    assert "the servo's limits" not in message  # the stored 4.5-14 V let it through
    assert not [p for p in rig.emulator.log.packets if p.packet.command.name.startswith("MOVE")]


def test_a_servo_in_motor_mode_is_refused_before_anything_moves():
    # MOVE_STOP cannot stop a servo in motor mode, so play must not start with one.
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.bus.set_motor_mode(5, 300)
    with pytest.raises(
        ChoreoError,
        match=r"wrist_roll \(ID 5\): is in motor mode \(turning at "
        r"duty 300\), which MOVE_STOP cannot stop; stop its motor first "
        r"\(choreo.bus.servo_config.stop_motor\)",
    ):
        rig.play()
    assert not [m for m in rig.emulator.log.moves if m.command == Command.MOVE_START]


def test_two_servos_sharing_an_id_are_refused_as_such():
    rig = Rig(f"{MOTIONS}/arm6/wave.yaml")
    rig.emulator = BusEmulator([*home_specs(rig.robot), ServoSpec(3)], clock=rig.clock)
    rig.bus = ServoBus(connection(rig.emulator))
    with pytest.raises(
        ChoreoError,
        match=r"1 servo\(s\) answered garbled, as when two servos "
        r"share an ID: elbow \(ID 3\)",
    ):
        rig.play()
