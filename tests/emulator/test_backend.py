"""The sim:// URL handler: opening through serial.serial_for_url, URL options and pyserial
semantics."""

from __future__ import annotations

import json

import pytest
import serial
from cli_helpers import error_line

from choreo.bus.protocol import Command as C
from choreo.bus.protocol import encode_request
from choreo.cli import main
from choreo.core.clock import RealClock, VirtualClock
from choreo.emulator import (
    BusEmulator,
    ServoSpec,
    SimSerial,
    parse_servo_specs,
    register_url_handler,
)
from choreo.emulator.protocol_sim import emulator_from_url

BYTE_S = 10 / 115200
POS_READ_500 = bytes.fromhex("55 55 01 05 1C F4 01 E8")


@pytest.fixture(autouse=True)
def handler():
    register_url_handler()


def open_url(url: str, **settings) -> SimSerial:
    return serial.serial_for_url(url, timeout=0.05, **settings)


def test_register_is_idempotent():
    register_url_handler()
    register_url_handler()
    assert serial.protocol_handler_packages.count("choreo.emulator") == 1


def test_serial_for_url_gives_an_open_serialbase_port_with_the_emulator():
    port = open_url("sim://?ids=1-3&clock=virtual")
    assert isinstance(port, serial.SerialBase) and isinstance(port, SimSerial)
    assert port.is_open
    assert isinstance(port.clock, VirtualClock) and port.clock is port.emulator.clock
    assert [s.servo_id for s in port.emulator.servos] == [1, 2, 3]
    port.write(encode_request(C.POS_READ, 3))
    assert port.read(8) == bytes.fromhex("55 55 03 05 1C F4 01 E6")


def test_defaults_are_six_lx16a_on_a_real_clock_without_echo():
    port = serial.serial_for_url("sim://", do_not_open=True)
    assert not port.is_open
    port.open()
    emulator = port.emulator
    assert [s.servo_id for s in emulator.servos] == [1, 2, 3, 4, 5, 6]
    assert {s.model.name for s in emulator.servos} == {"LX-16A"}
    assert isinstance(port.clock, RealClock)
    assert not emulator.echo and emulator.turnaround_s == 0.0006
    port.close()
    assert not port.is_open


def test_url_options_configure_the_emulator(tmp_path):
    state = tmp_path / "servos.json"
    port = open_url(
        f"sim://?ids=1-2,5:LX-224HV&model=HTD-35H&echo=1&turnaround_ms=2&clock=virtual"
        f"&state={state}&start_gap_ms=0&seed=3"
    )
    emulator = port.emulator
    assert [(s.servo_id, s.model.name) for s in emulator.servos] == [
        (1, "HTD-35H"),
        (2, "HTD-35H"),
        (5, "LX-224HV"),
    ]
    assert emulator.echo and emulator.turnaround_s == 0.002
    assert emulator.servos[0].start_gap_s == 0.0
    request = encode_request(C.ID_WRITE, 5, new_id=6)
    port.write(request)
    assert port.read(len(request)) == request  # echo
    saved = json.loads(state.read_text())
    assert [s["eeprom"]["servo_id"] for s in saved["servos"]] == [1, 2, 6]


@pytest.mark.parametrize(
    "url, message",
    [
        ("sim://?colour=red", "unknown option 'colour'"),
        ("sim://?clock=fast", "clock must be real or virtual"),
        ("sim://?echo=yes", "echo must be 0 or 1"),
        ("sim://?turnaround_ms=soon", "turnaround_ms must be a number of milliseconds"),
        ("sim://?seed=1.5", "seed must be a whole number, got '1.5'"),
        ("sim://?ids=1-x", "bad servo IDs '1-x'"),
        ("sim://?ids=300", r"bad servo IDs '300' \(servo IDs must be in 0..253"),
        ("sim://?ids=1-2,:LX-224HV", r"bad servo IDs ':LX-224HV' .*an ID or a range like 1-6"),
        ("sim://?model=LX-99", "known models: LX-16A"),
    ],
)
def test_bad_urls_raise_serial_exceptions_that_say_what_is_valid(url, message):
    with pytest.raises(serial.SerialException, match=message):
        serial.serial_for_url(url)


@pytest.mark.parametrize(
    "query, valid",
    [
        ("start_gap_ms=-1", ">= 0"),
        ("start_gap_ms=nan", ">= 0"),
        ("start_gap_ms=inf", ">= 0"),
        ("turnaround_ms=-1", "from 0 to 1000"),
        ("turnaround_ms=1001", "from 0 to 1000"),
        ("turnaround_ms=inf", "from 0 to 1000"),
    ],
)
def test_a_time_out_of_range_is_told_as_the_url_writes_it(query, valid):
    name, _, value = query.partition("=")
    with pytest.raises(ValueError) as raised:
        emulator_from_url(f"sim://?{query}")
    assert str(raised.value) == f"{name} must be a number of milliseconds {valid}, got {value!r}"


def test_the_command_line_tells_a_bad_url_option_in_one_line(capsys):
    assert main(["scan", "--port", "sim://?start_gap_ms=-1"]) == 1
    assert error_line(capsys) == (  # the port once, and no hint to list ports: it is not lost
        "choreo: error: cannot open sim://?start_gap_ms=-1: start_gap_ms must be a number of "
        "milliseconds >= 0, got '-1'"
    )


def test_parse_servo_specs():
    assert parse_servo_specs("1-3,9,12-13:LX-224HV") == [
        ServoSpec(1),
        ServoSpec(2),
        ServoSpec(3),
        ServoSpec(9),
        ServoSpec(12, "LX-224HV"),
        ServoSpec(13, "LX-224HV"),
    ]
    assert parse_servo_specs("2,2") == [ServoSpec(2), ServoSpec(2)]  # two servos share ID 2
    with pytest.raises(ValueError, match="low <= high"):
        parse_servo_specs("6-1")


def test_from_emulator_wraps_an_existing_emulator_with_settings():
    emulator = BusEmulator([1], clock=VirtualClock())
    port = SimSerial.from_emulator(emulator, timeout=0.2, baudrate=115200)
    assert port.is_open and port.emulator is emulator and port.timeout == 0.2
    port.write(encode_request(C.POS_READ, 1))
    assert port.read(8) == POS_READ_500


def test_read_returns_partial_data_after_the_timeout():
    port = open_url("sim://?ids=1&clock=virtual")
    port.write(encode_request(C.POS_READ, 1))
    assert port.read(20) == POS_READ_500
    assert port.clock.now() == pytest.approx(0.05)


def test_timeout_zero_returns_what_is_there_without_moving_the_clock():
    port = open_url("sim://?ids=1&clock=virtual")
    port.timeout = 0
    port.write(encode_request(C.POS_READ, 1))
    assert port.read(8) == b""
    assert port.clock.now() == 0.0
    port.clock.advance(0.01)
    assert port.in_waiting == 8
    assert port.read(8) == POS_READ_500


def test_timeout_none_waits_for_all_bytes_and_refuses_to_block_forever():
    port = open_url("sim://?ids=1&clock=virtual")
    port.timeout = None
    port.write(encode_request(C.POS_READ, 1))
    assert port.read(8) == POS_READ_500
    with pytest.raises(serial.SerialException, match="block forever"):
        port.read(1)


def test_read_until_and_context_manager_work():
    with open_url("sim://?ids=1&clock=virtual") as port:
        port.write(encode_request(C.POS_READ, 1))
        assert port.read_until(b"\x1c") == POS_READ_500[:5]
    assert not port.is_open


def test_using_a_closed_port_raises():
    port = open_url("sim://?ids=1&clock=virtual")
    port.close()
    with pytest.raises(serial.PortNotOpenError):
        port.write(b"\x55")
    with pytest.raises(serial.PortNotOpenError):
        port.read(1)


def test_closing_acts_on_what_has_crossed_the_wire(tmp_path):
    state = tmp_path / "s.json"
    port = open_url(f"sim://?ids=1&clock=virtual&state={state}")
    port.write(encode_request(C.ID_WRITE, 1, new_id=4))
    port.clock.advance(0.01)
    port.close()
    assert json.loads(state.read_text())["servos"][0]["eeprom"]["servo_id"] == 4


def test_real_clock_round_trip():
    # One request on the real clock (about 2 ms): the same code path works in real time.
    port = open_url("sim://?ids=1&clock=real")
    port.write(encode_request(C.POS_READ, 1))
    assert port.read(8) == POS_READ_500
    port.timeout = 0
    assert port.read(1) == b""


@pytest.mark.parametrize(
    "query,gap_s", [("", 0.0), ("&start_gap_ms=0", 0.0), ("&start_gap_ms=1", 0.001)]
)
def test_the_start_gap_fault_is_off_unless_the_url_sets_it(query, gap_s):
    port = open_url(f"sim://?ids=1&clock=virtual{query}")
    assert port.emulator.servos[0].start_gap_s == gap_s
    port.write(encode_request(C.MOVE_TIME_WAIT_WRITE, 1, pos_units=300, time_ms=0))
    port.write(encode_request(C.MOVE_START, 1))  # back to back
    port.flush()
    port.emulator.clock.advance(0.5)
    assert round(port.emulator.servo(1).position_units) == (500 if gap_s else 300)


@pytest.mark.parametrize(("query", "transport"), [("", "raw LX bus"), ("?board=rrc", "RRC board")])
def test_the_sim_backend_says_what_the_host_speaks_without_opening_anything(query, transport):
    from choreo.emulator import backend

    link = backend.link(f"sim://{query}")
    assert link.capabilities.transport == transport


def test_a_dry_run_on_an_emulated_board_prints_its_frames_and_a_bad_board_is_one_line(capsys):
    argv = ["play", "motions/arm6/wave.yaml", "--dry-run", "--port"]
    assert main([*argv, "sim://?board=lobot&ids=1-6"]) == 0
    out = capsys.readouterr().out
    assert "through the LOBOT controller: no staging, one move frame per tick" in out
    assert "55 55 17 03 06" in out  # the first tick: one LOBOT move frame for six servos
    assert main([*argv, "sim://?board=xyz"]) == 1
    assert error_line(capsys) == (
        "choreo: error: sim://?board=xyz: board must be one of rrc, lobot, got 'xyz'"
    )
