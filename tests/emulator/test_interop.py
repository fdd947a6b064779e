"""Drivers written by others, unchanged, against the emulator on a pty (issue 2 acceptance).

Two drivers from PyPI, used only through their public APIs:

- pylx16a 1.1.1 (``pylx16a.lx16a.LX16A``). The port is a class-level singleton opened by
  ``LX16A.initialize(port)``. ``LX16A(id)`` reads POS, OFFSET, ANGLE_LIMIT, VIN_LIMIT,
  TEMP_MAX_LIMIT, MOTOR_MODE (and the speed in motor mode), LOAD, LED_CTRL and LED_ERROR, then loads
  the servo. Replies are read as a fixed byte count with the checksum checked, nothing else.
  Importing it needs no display: the package is only ``pylx16a/lx16a.py`` (PyQt6 is a declared
  dependency that nothing imports).
- lewansoul-lx16a 0.1 (``lewansoul_lx16a.ServoController`` on a pyserial port). It scans for
  ``55 55``, skips packets with a bad checksum, another command or another servo's ID, and raises
  its own ``TimeoutError`` after ``timeout`` seconds.

Most tests host the :class:`PtyBridge` in this process (a background thread, real clock) so they can
look at ``emulator.servo(id)`` and ``emulator.log``; the last two run against a
``choreo emulate --pty`` subprocess, as a user would. Real clock by necessity: every wait polls with
a bound, none is a fixed sleep standing in for an assertion.

What the drivers cannot do (their bugs or limits, not the emulator's):

- pylx16a has no broadcast START: ``move_start()`` addresses the servo's own ID and the constructor
  refuses ID 254, so staged servos start one START packet (6 bytes, 0.52 ms) apart at best.
- Neither driver skips the echo of DIY one-wire wiring (``--echo``): pylx16a reads the 6-byte echo
  as the start of the reply (checksum error), lewansoul accepts the echo of a read request as the
  reply (same ID, command and a good checksum) and then fails indexing its missing parameters.
- Both read MOVE_TIME_WAIT_READ (cmd 8), which the LX-16A does not answer: they time out.
- pylx16a's ``set_angle_offset`` caches the offset's wire byte instead of the offset, so after a
  negative offset ``get_angle_offset()`` (cached) is wrong: -5° is sent as 235 and reported as
  56.4°. ``get_angle_offset(poll_hardware=True)`` reads the servo and is right.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import json
import signal
import subprocess
import sys
import threading
from dataclasses import asdict

import lewansoul_lx16a
import pytest
import serial
from emulated import served_on_a_pty, wait_for
from pylx16a.lx16a import LX16A, ServoTimeoutError

from choreo.bus.protocol import BROADCAST_ID, BYTE_TIME_S, Command, decode_request
from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator, Eeprom, ReplyFate, ServoSpec
from choreo.emulator.bus_emulator import STATE_FORMAT, STATE_VERSION

WAIT_S = 10  # bound on every wait; a passing test waits a few hundred ms at most
READ_TIMEOUT_S = (
    0.5  # the drivers' read timeout: pylx16a's 20 ms default is tight on a busy machine
)
NO_ANSWER_TIMEOUT_S = 0.05  # for reads that are expected to time out
START_PACKET_S = 6 * BYTE_TIME_S

# A servo whose every EEPROM value differs from the factory's, and its other readings.
CUSTOM_EEPROM = Eeprom(
    1,
    offset_units=-10,
    angle_min_units=100,
    angle_max_units=900,
    vin_min_mv=5000,
    vin_max_mv=11000,
    temp_max_c=80,
    led_off=1,
    error_mask=3,
)
CUSTOM_POSITION_UNITS = 300
CUSTOM_VIN_MV = 7400
CUSTOM_TEMP_C = 41


def at(emulator: BusEmulator, targets: dict[int, int]) -> bool:
    return all(
        emulator.servo(i).position_units == pytest.approx(units, abs=1e-6)
        for i, units in targets.items()
    )


def sent(emulator: BusEmulator, command: Command) -> list:
    return [p for p in emulator.log.packets if p.packet.command == command]


@pytest.fixture
def host(tmp_path):
    """``host(servos, model=..., eeproms={id: Eeprom})`` -> (emulator, link): a bridge served by a
    thread of this process on a real clock; ``eeproms`` seeds servos through a state file."""
    with contextlib.ExitStack() as running:
        hosted = itertools.count()

        def start(servos, *, model="LX-16A", eeproms=None):
            number = next(hosted)
            specs = [ServoSpec(s) if isinstance(s, int) else s for s in servos]
            state_path = None
            if eeproms:
                state_path = tmp_path / f"state{number}.json"
                state_path.write_text(
                    json.dumps(
                        {
                            "format": STATE_FORMAT,
                            "version": STATE_VERSION,
                            "servos": [
                                {
                                    "factory_id": s.servo_id,
                                    "model": model,
                                    "eeprom": asdict(eeproms.get(s.servo_id, Eeprom(s.servo_id))),
                                }
                                for s in specs
                            ],
                        }
                    )
                )
            emulator = BusEmulator(specs, model=model, clock=RealClock(), state_path=state_path)
            link = running.enter_context(served_on_a_pty(emulator, tmp_path / f"ttyEMU{number}"))
            return emulator, str(link)

        yield start


@pytest.fixture
def pylx16a_port():
    """``pylx16a_port(link)`` opens pylx16a's class-level port. pylx16a has no close(); the
    teardown closes and forgets the port so the next test starts as a fresh program would."""
    yield lambda link: LX16A.initialize(link, timeout=READ_TIMEOUT_S)
    if LX16A._controller is not None:
        LX16A._controller.close()
        LX16A._controller = None


@pytest.fixture
def lewansoul():
    """``lewansoul(link, timeout=...)`` -> a ServoController on a pyserial port, closed
    afterwards."""
    ports = []

    def open_controller(link, timeout=READ_TIMEOUT_S):
        ports.append(serial.Serial(link, 115200, timeout=timeout))
        return lewansoul_lx16a.ServoController(ports[-1], timeout=timeout)

    yield open_controller
    for port in ports:
        port.close()


def custom_bus(host):
    emulator, link = host(
        [ServoSpec(1, position_units=CUSTOM_POSITION_UNITS), ServoSpec(2, position_units=-12)],
        eeproms={1: CUSTOM_EEPROM},
    )
    emulator.servo(1).vin_mv = CUSTOM_VIN_MV
    emulator.servo(1).temperature_c = CUSTOM_TEMP_C
    return emulator, link


# --- pylx16a ------------------------------------------------------------------------------------
def test_pylx16a_constructor_reads_every_register_then_loads_the_servo(host, pylx16a_port):
    emulator, link = custom_bus(host)
    pylx16a_port(link)
    servo = LX16A(1)
    # A write crosses the wire after the driver returns: wait for its effect before looking.
    wait_for(lambda: emulator.servo(1).loaded, "servo 1 to be loaded")
    C = Command
    assert [p.packet.command for p in emulator.log.packets] == [
        C.POS_READ,
        C.ANGLE_OFFSET_READ,
        C.ANGLE_LIMIT_READ,
        C.VIN_LIMIT_READ,
        C.TEMP_MAX_LIMIT_READ,
        C.OR_MOTOR_MODE_READ,
        C.LOAD_OR_UNLOAD_READ,
        C.LED_CTRL_READ,
        C.LED_ERROR_READ,
        C.LOAD_OR_UNLOAD_WRITE,
    ]
    assert [r.fate for r in emulator.log.replies] == [ReplyFate.SENT] * 9
    assert decode_request(emulator.log.packets[-1].packet) == {"loaded": 1}
    # What the constructor read, as pylx16a reports it (degrees are units * 0.24).
    assert servo.get_angle_offset() == pytest.approx(-2.4)
    assert servo.get_angle_limits() == pytest.approx((24.0, 216.0))
    assert servo.get_vin_limits() == (5000, 11000)
    assert servo.get_temp_limit() == 80
    assert servo.is_motor_mode() is False
    assert servo.is_torque_enabled() is True
    assert servo.is_led_power_on() is False
    assert servo.get_led_error_triggers() == (True, True, False)
    assert servo.get_commanded_angle() == pytest.approx(72.0)


def test_pylx16a_reads_id_position_limits_vin_and_temperature(host, pylx16a_port):
    emulator, link = custom_bus(host)
    pylx16a_port(link)
    custom, factory = LX16A(1), LX16A(2)
    assert custom.get_id(poll_hardware=True) == 1
    assert custom.get_physical_angle() == pytest.approx(72.0)
    assert custom.get_angle_limits(poll_hardware=True) == pytest.approx((24.0, 216.0))
    assert custom.get_vin_limits(poll_hardware=True) == (5000, 11000)
    assert custom.get_vin() == 7400
    assert custom.get_temp() == 41
    assert custom.get_temp_limit(poll_hardware=True) == 80
    assert custom.get_angle_offset(poll_hardware=True) == pytest.approx(-2.4)
    assert custom.is_led_power_on(poll_hardware=True) is False
    assert custom.get_led_error_triggers(poll_hardware=True) == (True, True, False)
    assert custom.get_last_instant_move_hw() == (pytest.approx(72.0), 0)
    assert factory.get_id(poll_hardware=True) == 2
    assert factory.get_physical_angle() == pytest.approx(-2.88)  # POS_READ is signed
    assert factory.get_angle_limits(poll_hardware=True) == pytest.approx((0.0, 240.0))
    assert factory.get_vin_limits(poll_hardware=True) == (4500, 14000)
    assert factory.get_temp() == 30 and factory.get_temp_limit(poll_hardware=True) == 85
    assert factory.get_angle_offset(poll_hardware=True) == 0
    assert factory.is_led_power_on(poll_hardware=True) is True
    assert factory.get_led_error_triggers(poll_hardware=True) == (True, True, True)


def test_pylx16a_reads_motor_mode_and_speed(host, pylx16a_port):
    emulator, link = host([1])
    pylx16a_port(link)
    LX16A(1).motor_mode(-500)
    assert LX16A(1).get_motor_speed() == -500  # the new instance read mode and speed from the servo
    assert emulator.servo(1).motor_mode


def test_pylx16a_writes_reach_the_eeprom_and_read_back(host, pylx16a_port):
    emulator, link = host([1])
    pylx16a_port(link)
    servo = LX16A(1)
    servo.set_angle_offset(-5)  # degrees: round(-5 / 0.24) = -21 units, not saved
    assert servo.get_angle_offset(poll_hardware=True) == pytest.approx(-21 * 0.24)
    assert emulator.servo(1).offset_units == -21 and emulator.servo(1).eeprom.offset_units == 0
    servo.set_angle_offset(5, permanent=True)  # OFFSET_ADJUST then OFFSET_WRITE
    servo.set_angle_limits(30, 200)  # 125..833 units
    servo.set_vin_limits(5000, 12000)
    servo.set_temp_limit(70)
    servo.led_power_off()
    servo.set_led_error_triggers(over_temperature=False, over_voltage=True, rotor_locked=True)
    assert servo.get_angle_limits(poll_hardware=True) == pytest.approx((30.0, 833 * 0.24))
    assert servo.get_vin_limits(poll_hardware=True) == (5000, 12000)
    assert servo.get_temp_limit(poll_hardware=True) == 70
    assert servo.is_led_power_on(poll_hardware=True) is False
    assert servo.get_led_error_triggers(poll_hardware=True) == (False, True, True)
    assert emulator.servo(1).eeprom == Eeprom(
        1,
        offset_units=21,
        angle_min_units=125,
        angle_max_units=833,
        vin_min_mv=5000,
        vin_max_mv=12000,
        temp_max_c=70,
        led_off=1,
        error_mask=6,
    )
    servo.set_id(5)
    assert servo.get_id(poll_hardware=True) == 5 and emulator.servo(5).eeprom.servo_id == 5


def test_pylx16a_move_time_write_gets_there(host, pylx16a_port):
    emulator, link = host([ServoSpec(1, position_units=300)])
    pylx16a_port(link)
    servo = LX16A(1)
    servo.move(120.0, time=200)  # 120° = 500 units
    wait_for(lambda: at(emulator, {1: 500}), "servo 1 to reach 500")
    (move_packet,) = sent(emulator, Command.MOVE_TIME_WRITE)
    assert decode_request(move_packet.packet) == {"pos_units": 500, "time_ms": 200}
    (move,) = emulator.log.moves
    assert (move.servo_id, move.from_units, move.to_units) == (1, 300, 500)
    assert move.duration_s == pytest.approx(0.2) and move.time_s == move_packet.time_s
    assert servo.get_physical_angle() == pytest.approx(120.0)
    assert servo.get_last_instant_move_hw() == (pytest.approx(120.0), 200)


def test_pylx16a_staged_moves_wait_for_start_then_start_one_start_packet_apart(host, pylx16a_port):
    emulator, link = host([1, 2, 3])
    pylx16a_port(link)
    servos = [LX16A(i) for i in (1, 2, 3)]
    for servo, angle in zip(servos, (96.0, 144.0, 108.0)):  # 400, 600, 450 units
        servo.move(angle, time=150, wait=True)
    # Read back through pylx16a: nothing moved. (This also leaves the >= 1 ms between the last
    # preset and a START that protocol.md asks for.)
    assert [s.get_physical_angle() for s in servos] == pytest.approx([120.0] * 3)
    assert not emulator.log.moves and at(emulator, {1: 500, 2: 500, 3: 500})
    for servo in servos:
        servo.move_start()
    wait_for(lambda: at(emulator, {1: 400, 2: 600, 3: 450}), "the staged targets")
    starts = sent(emulator, Command.MOVE_START)
    assert [p.packet.servo_id for p in starts] == [1, 2, 3]  # no broadcast START in pylx16a
    moves = list(emulator.log.moves)
    assert [(m.servo_id, m.command, m.to_units) for m in moves] == [
        (1, Command.MOVE_START, 400),
        (2, Command.MOVE_START, 600),
        (3, Command.MOVE_START, 450),
    ]
    assert [m.time_s for m in moves] == [p.time_s for p in starts]  # each at its own START
    assert moves[2].time_s - moves[0].time_s >= 2 * START_PACKET_S - 1e-9
    assert [s.get_physical_angle() for s in servos] == pytest.approx([96.0, 144.0, 108.0])


def test_pylx16a_wait_read_times_out_on_an_lx16a_and_is_answered_by_an_lx224hv(host, pylx16a_port):
    _, lx16a_link = host([1])
    pylx16a_port(lx16a_link)
    servo = LX16A(1)
    servo.move(60.0, time=300, wait=True)
    LX16A.set_timeout(NO_ANSWER_TIMEOUT_S)
    with pytest.raises(ServoTimeoutError):
        servo.get_last_delayed_move_hw()  # the LX-16A does not answer cmd 8
    LX16A.set_timeout(READ_TIMEOUT_S)
    _, lx224_link = host([1], model="LX-224HV")
    pylx16a_port(lx224_link)
    servo = LX16A(1)
    servo.move(60.0, time=300, wait=True)
    assert servo.get_last_delayed_move_hw() == (pytest.approx(60.0), 300)


# --- lewansoul-lx16a ----------------------------------------------------------------------------
def test_lewansoul_reads_id_position_limits_vin_temperature_and_modes(host, lewansoul):
    emulator, link = custom_bus(host)
    controller = lewansoul(link)
    assert controller.get_servo_id(1) == 1
    assert controller.get_position(1) == 300
    assert controller.get_position_offset(1) == -10
    assert controller.get_position_limits(1) == (100, 900)
    assert controller.get_voltage_limits(1) == (5000, 11000)
    assert controller.get_voltage(1) == 7400
    assert controller.get_temperature(1) == 41
    assert controller.get_max_temperature_limit(1) == 80
    assert controller.get_mode(1) == 0 and controller.get_motor_speed(1) == 0
    assert controller.is_motor_on(1) is False  # servos power up unloaded
    assert controller.is_led_on(1) is False
    assert controller.get_led_errors(1) == 3
    factory = controller.servo(2)  # the per-servo proxy
    assert factory.get_position() == -12  # POS_READ is signed
    assert factory.get_position_limits() == (0, 1000)
    assert factory.get_voltage_limits() == (4500, 14000)
    assert factory.get_voltage() == 7200 and factory.get_temperature() == 30
    assert factory.get_position_offset() == 0 and factory.is_led_on() is True
    assert all(r.fate is ReplyFate.SENT for r in emulator.log.replies)


def test_lewansoul_writes_reach_the_eeprom_and_read_back(host, lewansoul):
    emulator, link = host([1])
    controller = lewansoul(link)
    controller.set_position_limits(1, 200, 800)
    controller.set_voltage_limits(1, 6000, 8400)
    controller.set_max_temperature_limit(1, 70)
    controller.set_position_offset(1, 25)
    controller.save_position_offset(1)
    controller.led_off(1)
    controller.set_led_errors(1, 4)
    controller.motor_on(1)
    assert controller.get_position_limits(1) == (200, 800)
    assert controller.get_voltage_limits(1) == (6000, 8400)
    assert controller.get_max_temperature_limit(1) == 70
    assert controller.get_position_offset(1) == 25
    assert controller.is_led_on(1) is False and controller.get_led_errors(1) == 4
    assert controller.is_motor_on(1) is True and emulator.servo(1).loaded
    assert emulator.servo(1).eeprom == Eeprom(
        1,
        offset_units=25,
        angle_min_units=200,
        angle_max_units=800,
        vin_min_mv=6000,
        vin_max_mv=8400,
        temp_max_c=70,
        led_off=1,
        error_mask=4,
    )
    controller.set_servo_id(1, 9)
    assert controller.get_servo_id(9) == 9 and emulator.servo(9).eeprom.servo_id == 9


def test_lewansoul_broadcast_id_read_finds_a_lone_servo_and_times_out_on_a_collision(
    host, lewansoul, caplog
):
    _, lone_link = host([7])
    assert lewansoul(lone_link).get_servo_id() == 7  # broadcast by default; the reply says 7
    emulator, crowd_link = host([1, 2, 3])
    with pytest.raises(lewansoul_lx16a.TimeoutError):
        lewansoul(crowd_link).get_servo_id(timeout=NO_ANSWER_TIMEOUT_S)
    assert emulator.log.replies[-1].fate is ReplyFate.COLLIDED
    assert "Invalid checksum" in caplog.text  # the garbled reply was seen and skipped


def test_lewansoul_prepared_move_read_times_out_on_an_lx16a_only(host, lewansoul):
    _, lx16a_link = host([1])
    controller = lewansoul(lx16a_link)
    controller.move_prepare(1, 250, 300)
    with pytest.raises(lewansoul_lx16a.TimeoutError):
        controller.get_prepared_move(1, timeout=NO_ANSWER_TIMEOUT_S)
    _, lx224_link = host([1], model="LX-224HV")
    controller = lewansoul(lx224_link)
    controller.move_prepare(1, 250, 300)
    assert controller.get_prepared_move(1) == (250, 300)


def test_lewansoul_move_time_write_gets_there(host, lewansoul):
    emulator, link = host([ServoSpec(1, position_units=300)])
    controller = lewansoul(link)
    controller.move(1, 450, 150)
    wait_for(lambda: at(emulator, {1: 450}), "servo 1 to reach 450")
    (move,) = emulator.log.moves
    assert (move.servo_id, move.command, move.from_units, move.to_units) == (
        1,
        Command.MOVE_TIME_WRITE,
        300,
        450,
    )
    assert move.duration_s == pytest.approx(0.15)
    assert controller.get_position(1) == 450
    assert controller.is_motor_on(1) is True  # a move loads the servo


def test_lewansoul_staged_moves_start_together_on_a_broadcast_start(host, lewansoul):
    emulator, link = host([1, 2, 3])
    controller = lewansoul(link)
    targets = {1: 400, 2: 600, 3: 450}
    for servo_id, units in targets.items():
        controller.move_prepare(servo_id, units, 150)
    # Read back: nothing moved (this also leaves the >= 1 ms gap before START, see protocol.md).
    assert [controller.get_position(i) for i in targets] == [500, 500, 500]
    assert not emulator.log.moves and at(emulator, {1: 500, 2: 500, 3: 500})
    controller.move_start()  # broadcast by default
    wait_for(lambda: at(emulator, targets), "the staged targets")
    (start,) = sent(emulator, Command.MOVE_START)
    assert start.packet.servo_id == BROADCAST_ID
    moves = list(emulator.log.moves)
    assert {m.servo_id: m.to_units for m in moves} == targets
    assert {m.time_s for m in moves} == {start.time_s}  # one instant, the START's arrival
    assert all(m.command is Command.MOVE_START for m in moves)
    assert [controller.get_position(i) for i in targets] == list(targets.values())


# --- both drivers against `choreo emulate --pty` in another process -----------------------------
@pytest.fixture(scope="module")
def emulate_process(tmp_path_factory):
    """``choreo emulate --pty`` with servos 1-6: pylx16a's test uses 1-3, lewansoul's 4-6."""
    link = tmp_path_factory.mktemp("emulate") / "ttyEMU"
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "emulate", "--pty", str(link), "--servos", "1-6"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    watchdog = threading.Timer(WAIT_S * 3, process.kill)  # a hung start fails instead of hanging
    watchdog.start()
    try:
        ready = process.stdout.readline()
    finally:
        watchdog.cancel()
    assert ready.startswith("emulating servos 1-6"), process.stderr.read()
    yield str(link)
    process.send_signal(signal.SIGINT)
    try:
        process.communicate(timeout=WAIT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    assert process.returncode == 130  # stopped by Ctrl-C, as a shell reports it


def wait_until_read(read, expected, what: str) -> None:
    wait_for(lambda: read() == expected, what)


def test_pylx16a_on_the_emulate_command(emulate_process, pylx16a_port):
    pylx16a_port(emulate_process)
    servos = [LX16A(i) for i in (1, 2, 3)]
    first = servos[0]
    assert first.get_id(poll_hardware=True) == 1 and first.get_physical_angle() == pytest.approx(
        120.0
    )
    assert first.get_angle_limits(poll_hardware=True) == pytest.approx((0.0, 240.0))
    assert first.get_vin_limits(poll_hardware=True) == (4500, 14000)
    assert first.get_vin() == 7200 and first.get_temp() == 30
    first.move(72.0, time=100)  # 300 units
    wait_until_read(first.get_physical_angle, pytest.approx(72.0), "servo 1 at 72°")
    for servo in servos:
        servo.move(144.0, time=100, wait=True)
    angles = [s.get_physical_angle() for s in servos]
    assert angles == pytest.approx([72.0, 120.0, 120.0])  # staged, not moving
    for servo in servos:
        servo.move_start()
    for number, servo in enumerate(servos, 1):
        wait_until_read(servo.get_physical_angle, pytest.approx(144.0), f"servo {number} at 144°")


def test_lewansoul_on_the_emulate_command(emulate_process, lewansoul):
    controller = lewansoul(emulate_process)
    assert controller.get_servo_id(4) == 4 and controller.get_position(4) == 500
    assert controller.get_position_limits(4) == (0, 1000)
    assert controller.get_voltage_limits(4) == (4500, 14000)
    assert controller.get_voltage(4) == 7200 and controller.get_temperature(4) == 30
    controller.move(4, 300, 100)
    wait_until_read(lambda: controller.get_position(4), 300, "servo 4 at 300")
    targets = {4: 700, 5: 650, 6: 600}
    for servo_id, units in targets.items():
        controller.move_prepare(servo_id, units, 100)
    assert [controller.get_position(i) for i in targets] == [300, 500, 500]  # staged, not moving
    controller.move_start()
    for servo_id, units in targets.items():
        read = functools.partial(controller.get_position, servo_id)
        wait_until_read(read, units, f"servo {servo_id} at {units}")
