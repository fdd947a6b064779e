"""Servo configuration (choreo.bus.servo_config and `choreo servo ...`) against the emulator in
virtual time.

Expected bytes come from docs/protocol.md's verified packets, not from the codec.
"""

from __future__ import annotations

import math

import pytest
from emulated import sent

from choreo.bus import servo_config
from choreo.bus.protocol import BROADCAST_ID, Command, ErrorMask, PacketDecoder
from choreo.bus.servo_bus import ServoBus
from choreo.bus.typed_commands import AngleLimits, VinLimits
from choreo.cli import flag_of
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ReplyFaults, SimSerial
from choreo.errors import BusError


class LossySerial(SimSerial):
    """A port whose cable loses every packet of the commands in ``lost`` on the way out."""

    lost: tuple[Command, ...] = ()

    def write(self, data) -> int:
        packets = PacketDecoder().feed(bytes(data))
        if packets and all(p.command in self.lost for p in packets):
            return len(data)
        return super().write(data)


def make_bus(ids=(1,), *, lost=()):
    emulator = BusEmulator(ids, clock=VirtualClock())
    port = LossySerial.from_emulator(emulator)
    port.lost = lost
    return ServoBus(port), emulator


# --- EEPROM settings ---------------------------------------------------------------------------
SETTINGS = [
    (servo_config.TEMP_LIMIT, 70, {"temp_max_c": 70}, "55 55 01 04 18 46 9C"),
    (
        servo_config.ANGLE_LIMITS,
        AngleLimits(100, 900),
        {"angle_min_units": 100, "angle_max_units": 900},
        "55 55 01 07 14 64 00 84 03 F8",
    ),
    (
        servo_config.VIN_LIMITS,
        VinLimits(4500, 12000),
        {"vin_min_mv": 4500, "vin_max_mv": 12000},
        "55 55 01 07 16 94 11 E0 2E 2E",
    ),
    (servo_config.LED, False, {"led_off": 1}, "55 55 01 04 21 01 D8"),
    (servo_config.LED_ERRORS, ErrorMask(7), {"error_mask": 7}, "55 55 01 04 23 07 D0"),
]


@pytest.mark.parametrize(
    "setting, value, saved, packet_hex", SETTINGS, ids=lambda v: getattr(v, "name", "")
)
def test_a_setting_is_shown_old_to_new_written_and_saved(setting, value, saved, packet_hex):
    bus, emulator = make_bus()
    if setting is servo_config.LED_ERRORS:
        bus.set_led_errors(1, ErrorMask.NONE)
        bus.drain()
    writes_before = len(sent(emulator, setting.command))
    change = servo_config.plan_change(bus, 1, setting, value)
    assert change.new == value and change.old != value and not change.unchanged
    assert len(sent(emulator, setting.command)) == writes_before  # planning writes nothing
    servo_config.apply_change(bus, change)
    eeprom = emulator.servo(1).eeprom
    assert {name: getattr(eeprom, name) for name in saved} == saved
    assert sent(emulator, setting.command)[-1].encode() == bytes.fromhex(packet_hex)


def test_the_summary_reads_old_to_new():
    bus, _ = make_bus()
    change = servo_config.plan_change(bus, 1, servo_config.ANGLE_LIMITS, AngleLimits(100, 900))
    assert str(change) == (
        "servo 1: angle limits 0 (0.0°)..1000 (240.0°) → 100 (24.0°)..900 (216.0°)"
    )


@pytest.mark.parametrize(
    "setting, value, words",
    [
        (servo_config.TEMP_LIMIT, 101, "temp_c must be in 50..100"),
        (servo_config.TEMP_LIMIT, 49, "temp_c must be in 50..100"),
        (servo_config.ANGLE_LIMITS, AngleLimits(0, 1001), "max_units must be in 0..1000"),
        (servo_config.ANGLE_LIMITS, AngleLimits(600, 400), "min_units must be less than max_units"),
        (servo_config.VIN_LIMITS, VinLimits(4000, 9000), "min_mv must be in 4500..14000"),
        (servo_config.LED_ERRORS, 8, "mask must be in 0..7"),
    ],
)
def test_out_of_range_values_are_refused_before_anything_is_sent(setting, value, words):
    bus, emulator = make_bus()
    with pytest.raises(ValueError, match=words):
        servo_config.plan_change(bus, 1, setting, value)
    assert list(emulator.log.packets) == []


def test_a_warning_when_the_new_limit_stops_the_servo_at_once():
    bus, emulator = make_bus()
    emulator.servo(1).temperature_c = 62
    change = servo_config.plan_change(bus, 1, servo_config.TEMP_LIMIT, 60)
    assert "62 °C now, above the new limit" in change.warning
    assert servo_config.plan_change(bus, 1, servo_config.TEMP_LIMIT, 70).warning is None
    vin = servo_config.plan_change(bus, 1, servo_config.VIN_LIMITS, VinLimits(9000, 12000))
    assert "7200 mV now, outside the new limits" in vin.warning


def test_a_write_lost_on_the_wire_is_a_mismatch_naming_the_value():
    bus, emulator = make_bus(lost=(Command.TEMP_MAX_LIMIT_WRITE,))
    change = servo_config.plan_change(bus, 1, servo_config.TEMP_LIMIT, 70)
    with pytest.raises(
        BusError,
        match="servo 1: temperature limit reads 85 °C after writing 70 °C: the write did not take",
    ):
        servo_config.apply_change(bus, change)
    assert emulator.servo(1).eeprom.temp_max_c == 85


def test_a_servo_that_stops_answering_fails_the_read_back():
    bus, emulator = make_bus()
    change = servo_config.plan_change(bus, 1, servo_config.LED, False)
    emulator.servo(1).connected = False
    with pytest.raises(BusError, match="servo 1: wrote LED off but could not read it back"):
        servo_config.apply_change(bus, change)


def test_broadcast_is_not_a_servo_to_configure():
    bus, emulator = make_bus()
    with pytest.raises(ValueError, match="no broadcast"):
        servo_config.plan_change(bus, BROADCAST_ID, servo_config.TEMP_LIMIT, 70)


@pytest.mark.parametrize(
    "text, mask",
    [
        ("none", ErrorMask.NONE),
        ("all", ErrorMask(7)),
        ("5", ErrorMask(5)),
        ("stalled", ErrorMask.STALLED),
        ("voltage, over-temperature", ErrorMask(3)),
    ],
)
def test_fault_masks_parse_by_name_or_number(text, mask):
    assert servo_config.parse_error_mask(text) == mask


@pytest.mark.parametrize("text", ["8", "volts", ""])
def test_bad_fault_masks_list_the_valid_names(text):
    with pytest.raises(ValueError, match="over-temperature, voltage, stalled"):
        servo_config.parse_error_mask(text)


# --- offset ------------------------------------------------------------------------------------
def test_offset_adjust_applies_at_once_and_save_persists():
    bus, emulator = make_bus()
    units = servo_config.offset_units_from_deg(-2.4)
    assert units == -10
    servo_config.adjust_offset(bus, 1, units)
    assert sent(emulator, Command.ANGLE_OFFSET_ADJUST)[-1].encode() == bytes.fromhex(
        "55 55 01 04 11 F6 F3"
    )
    assert emulator.servo(1).offset_units == -10
    assert emulator.servo(1).eeprom.offset_units == 0  # not saved yet
    change = servo_config.plan_offset_save(bus, 1)
    assert str(change) == (
        "servo 1: saved offset unknown (servos report only the offset in use) → -10 (-2.4°)"
    )
    servo_config.apply_change(bus, change)
    assert sent(emulator, Command.ANGLE_OFFSET_WRITE)[-1].encode() == bytes.fromhex(
        "55 55 01 03 12 E9"
    )
    assert emulator.servo(1).eeprom.offset_units == -10


@pytest.mark.parametrize("offset_deg", [30.3, -31, 1e308, -1e308, math.nan])
def test_offset_beyond_30_degrees_is_refused_with_the_range(offset_deg):
    with pytest.raises(ValueError, match=r"within -30.0..\+30.0° \(-125..125 units\)"):
        servo_config.offset_units_from_deg(offset_deg)


def test_offset_adjust_out_of_range_units_sends_nothing():
    bus, emulator = make_bus()
    with pytest.raises(ValueError, match="offset_units must be in -125..125"):
        servo_config.adjust_offset(bus, 1, 126)
    assert list(emulator.log.packets) == []


# --- set-id ------------------------------------------------------------------------------------
def test_set_id_finds_the_lone_servo_and_addresses_it_never_broadcast():
    bus, emulator = make_bus(ids=(1,))
    change = servo_config.plan_id_change(bus, 5)
    assert (change.current_id, change.new_id, change.found_alone) == (1, 5, True)
    servo_config.apply_id_change(bus, change)
    assert emulator.servo(5).eeprom.servo_id == 5
    (write,) = sent(emulator, Command.ID_WRITE)
    assert write.encode() == bytes.fromhex("55 55 01 04 0D 05 E8")
    reads = sent(emulator, Command.ID_READ)
    assert reads[0].servo_id == BROADCAST_ID  # the search starts with a broadcast read...
    assert len({p.servo_id for p in reads}) > 200  # ...and scans every ID


def test_set_id_refuses_two_servos_whose_broadcast_replies_collide_listing_them():
    bus, emulator = make_bus(ids=(1, 2))
    with pytest.raises(
        BusError,
        match="exactly one servo on the bus, but several servos answered "
        r"a broadcast ID read at once \(their replies collided\); "
        "IDs 1, 2 answer: connect only the servo",
    ):
        servo_config.plan_id_change(bus, 5)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_refuses_two_servos_sharing_an_id():
    bus, emulator = make_bus(ids=(4, 4))
    with pytest.raises(
        BusError, match=r"replies at IDs 4 are garbled \(several servos share each "
    ):
        servo_config.plan_id_change(bus, 5)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_refuses_a_given_current_id_that_two_servos_share():
    bus, emulator = make_bus(ids=(4, 4))
    with pytest.raises(BusError, match="replies at ID 4 are garbled: several servos share it"):
        servo_config.plan_id_change(bus, 5, current_id=4)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_refuses_a_new_id_that_two_servos_share():
    bus, emulator = make_bus(ids=(1, 2, 2))
    with pytest.raises(BusError, match="ID 2 is already used by another servo"):
        servo_config.plan_id_change(bus, 2, current_id=1)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_refuses_a_lone_broadcast_answer_when_the_scan_finds_a_shared_id():
    bus, emulator = make_bus(ids=(1, 3, 3))
    for servo in emulator.servos[1:]:
        servo.reply_faults = ReplyFaults(drop_next=1)  # so the broadcast hears only servo 1
    with pytest.raises(BusError, match=r"IDs 1 answer; replies at IDs 3 are garbled"):
        servo_config.plan_id_change(bus, 5)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_refuses_a_second_servo_found_by_the_scan_listing_both():
    bus, emulator = make_bus(ids=(1, 7))
    emulator.servo(7).reply_faults = ReplyFaults(drop_next=1)  # so the broadcast finds only 1
    with pytest.raises(BusError) as caught:
        servo_config.plan_id_change(bus, 5)
    assert str(caught.value) == (
        "setting an ID without its current one needs exactly one servo on the bus, but IDs 1, 7 "
        "answer: connect only the servo to renumber, or give its current ID (current_id)"
    )
    assert caught.value.worded(flag_of).endswith("or give its current ID (--id)")
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_with_no_servo_says_so():
    bus, _ = make_bus(ids=())
    with pytest.raises(BusError, match="no servo answered a broadcast ID read nor the scan"):
        servo_config.plan_id_change(bus, 5)


def test_set_id_refuses_an_id_in_use():
    bus, emulator = make_bus(ids=(1, 2))
    with pytest.raises(BusError, match="ID 2 is already used by another servo"):
        servo_config.plan_id_change(bus, 2, current_id=1)
    assert sent(emulator, Command.ID_WRITE) == []


def test_set_id_with_a_current_id_nobody_answers():
    bus, _ = make_bus(ids=(1, 2))
    with pytest.raises(BusError, match="no servo answers at ID 4"):
        servo_config.plan_id_change(bus, 5, current_id=4)


def test_set_id_with_a_known_id_renumbers_only_that_servo():
    bus, emulator = make_bus(ids=(1, 2))
    servo_config.apply_id_change(bus, servo_config.plan_id_change(bus, 9, current_id=2))
    assert [s.servo_id for s in emulator.servos] == [1, 9]
    assert all(p.servo_id == 2 for p in sent(emulator, Command.ID_WRITE))


def test_set_id_to_the_same_id_is_nothing_to_do():
    bus, _ = make_bus(ids=(3,))
    assert servo_config.plan_id_change(bus, 3, current_id=3).unchanged


def test_set_id_whose_write_is_lost_says_the_servo_kept_its_id():
    bus, emulator = make_bus(ids=(1,), lost=(Command.ID_WRITE,))
    change = servo_config.plan_id_change(bus, 5, current_id=1)
    with pytest.raises(BusError, match="no servo answers at 5 \\(it still answers at 1\\)"):
        servo_config.apply_id_change(bus, change)
    assert emulator.servo(1).eeprom.servo_id == 1


def test_set_id_refuses_an_out_of_range_id_before_sending():
    bus, emulator = make_bus()
    with pytest.raises(ValueError, match="new_id must be in 0..253"):
        servo_config.plan_id_change(bus, 254, current_id=1)
    assert list(emulator.log.packets) == []


# --- move, torque, motor -----------------------------------------------------------------------
def test_move_goes_there():
    bus, emulator = make_bus()
    servo_config.move(bus, 1, servo_config.position_units_from_deg(168), 400)
    emulator.clock.advance(0.5)
    assert emulator.servo(1).position_units == pytest.approx(700)


def test_move_outside_the_servos_angle_limits_is_refused_not_clamped():
    bus, emulator = make_bus()
    bus.set_angle_limits(1, 100, 900)
    with pytest.raises(BusError, match="position 950 is outside its angle limits 100..900"):
        servo_config.move(bus, 1, 950, 500)
    assert sent(emulator, Command.MOVE_TIME_WRITE) == []


def test_move_in_motor_mode_is_refused():
    bus, emulator = make_bus()
    servo_config.run_motor(bus, 1, 300)
    with pytest.raises(BusError, match="motor mode and ignores moves"):
        servo_config.move(bus, 1, 600, 500)


@pytest.mark.parametrize("angle_deg", [-1, 240.2, 1e308, -1e308, math.nan])
def test_move_angles_outside_the_servo_travel_are_refused(angle_deg):
    with pytest.raises(ValueError, match=r"0..240° \(0..1000 units\)"):
        servo_config.position_units_from_deg(angle_deg)


def test_load_and_unload_are_verified():
    bus, emulator = make_bus()
    servo_config.set_torque(bus, 1, True)
    assert emulator.servo(1).loaded
    servo_config.set_torque(bus, 1, False)
    assert not emulator.servo(1).loaded
    emulator.servo(1).vin_mv = 4000  # below the VIN limit: the servo refuses torque
    with pytest.raises(BusError, match="servo 1 did not load"):
        servo_config.set_torque(bus, 1, True)


def test_motor_runs_and_stops():
    bus, emulator = make_bus()
    servo_config.run_motor(bus, 1, -500)
    assert emulator.servo(1).motor_mode
    assert sent(emulator, Command.OR_MOTOR_MODE_WRITE)[-1].encode() == bytes.fromhex(
        "55 55 01 07 1D 01 00 0C FE CF"
    )
    servo_config.stop_motor(bus, 1)
    assert not emulator.servo(1).motor_mode and emulator.servo(1).loaded


def test_motor_speed_out_of_range_sends_nothing():
    bus, emulator = make_bus()
    with pytest.raises(ValueError, match="speed must be in -1000..1000"):
        servo_config.run_motor(bus, 1, 1001)
    assert list(emulator.log.packets) == []
