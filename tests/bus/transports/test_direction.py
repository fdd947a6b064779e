"""GPIO half-duplex direction control on a Pi/Jetson UART, against fake enable lines that lose
what a real HAT would lose: host bytes sent while transmit is off, replies while receive is off."""

from __future__ import annotations

import subprocess
import sys

import pytest
from direction_helpers import LATE_DRAINS_S, gated_bus

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports.direction import (
    PRESETS,
    DirectionPins,
    DirectionSerial,
    board_pins,
    parse_direction,
)
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial
from choreo.emulator.direction_gate import FakeDirectionLines
from choreo.errors import BusTimeoutError, ChoreoError


def test_reads_and_writes_work_with_transmit_only_while_writing():
    bus, emulator, lines = gated_bus()
    with bus:
        assert bus.read_position(2) == 500
        bus.move(2, 300, 0)
        assert bus.scan(range(0, 5)) == [1, 2, 3]
    # every packet reached the servos, and each change came in the order the HAT needs
    assert [p.packet.command for p in emulator.log.packets][:2] == [
        Command.POS_READ,
        Command.MOVE_TIME_WRITE,
    ]
    states = [(tx, rx) for _, tx, rx in lines.changes[1:]]
    assert states[:3] == [(False, True), (True, False), (False, True)]
    assert all(a != b for a, b in zip(states, states[1:]))  # never both on, never a no-op


def test_an_echoing_wire_brings_no_echo_through_the_gate():
    bus, _, _ = gated_bus(echo=True)
    with bus:
        assert bus.read_vin(1) == 7200
        assert bus.port.in_waiting == 0


@pytest.mark.parametrize("late_s", LATE_DRAINS_S)
def test_the_turnaround_does_not_wait_for_a_late_drain(late_s):
    bus, emulator, lines = gated_bus(drain_late_s=late_s)
    with bus:
        assert bus.read_position(2) == 500
        assert bus.scan(range(0, 5)) == [1, 2, 3]
        bus.move(2, 300, 0)
        assert bus.read_position(1) == 500
    # receive came on once each request's last stop bit had left, before any servo answered
    request_ends = [p.time_s for p in emulator.log.packets]
    receive_on = [t for t, tx, rx in lines.changes if rx]
    for end_s in request_ends:
        after = [t for t in receive_on if t >= end_s]
        assert after and after[0] - end_s < emulator.turnaround_s


def test_staged_writes_cost_their_wire_time_not_a_jiffy_each():
    bus, emulator, _ = gated_bus(drain_late_s=0.004)
    with bus:
        start_s = emulator.clock.now()
        for servo_id in (1, 2, 3):
            bus.send(Command.MOVE_TIME_WAIT_WRITE, servo_id, pos_units=400, time_ms=0)
        bus.send(Command.MOVE_START, 254)
        elapsed_s = emulator.clock.now() - start_s
    wire_s = (3 * 10 + 6) * 10 / 115200
    assert wire_s <= elapsed_s < wire_s + 4 * 0.0004  # a margin per write, no 4 ms drain


def test_a_staged_tick_is_one_transmit_window_and_the_line_turns_around_after_it():
    bus, emulator, lines = gated_bus(drain_late_s=0.004)
    with bus:
        before = len(lines.changes)
        start_s = emulator.clock.now()
        assert bus.stage_many([(3, 400), (1, 450), (2, 550)], 200) == 30
        staged_s = emulator.clock.now() - start_s
        window = [(tx, rx) for _, tx, rx in lines.changes[before:]]
        bus.start()
        assert bus.read_position(2) == 500  # the reply came through: receive was on in time
        emulator.clock.advance(0.3)
        assert [bus.read_position(i) for i in (1, 2, 3)] == [450, 550, 400]
    # transmit on once, receive on once, after the last stop bit of the third move
    assert window == [(True, False), (False, True)]
    wire_s = 30 * 10 / 115200
    assert wire_s <= staged_s < wire_s + 0.0004  # one margin, not one per servo
    staged = [p for p in emulator.log.packets if p.packet.command == Command.MOVE_TIME_WAIT_WRITE]
    assert [p.packet.servo_id for p in staged] == [3, 1, 2]  # whole, in the order written
    receive_on = [t for t, tx, rx in lines.changes if rx and t >= staged[-1].time_s]
    assert receive_on[0] - staged[-1].time_s < emulator.turnaround_s


class NoStatusRegister:
    """A UART driver without TIOCSERGETLSR (many USB adapters): only the computed time."""

    def __init__(self, port):
        self._port = port

    def __getattr__(self, name):
        if name == "transmitter_empty":
            raise AttributeError(name)
        return getattr(self._port, name)


def test_without_a_status_register_the_computed_end_is_enough():
    emulator = BusEmulator(range(1, 4), clock=VirtualClock())
    lines = FakeDirectionLines(emulator, drain_late_s=0.010)
    sim = SimSerial.from_emulator(emulator, timeout=0.05, baudrate=115200)
    port = DirectionSerial(NoStatusRegister(sim), lines, clock=emulator.clock)
    assert not port.has_status_register
    with ServoBus(port, retries=0, echo="none") as bus:
        assert bus.read_position(3) == 500


def test_a_pipe_has_no_line_status_register():
    import os

    from choreo.bus.transports.direction import transmitter_empty

    read_end, write_end = os.pipe()
    try:
        with open(read_end, "rb", buffering=0) as pipe:
            assert transmitter_empty(pipe) is None
    finally:
        os.close(write_end)


def test_presets_and_explicit_pins():
    assert parse_direction("tonypi") == DirectionPins(rx=4, tx=27)
    assert parse_direction("ainex") == DirectionPins(rx=19, tx=26)
    assert parse_direction("jethexa") == DirectionPins(rx=17, tx=27)
    assert parse_direction("rx=5,tx=6,chip=/dev/gpiochip4") == DirectionPins(5, 6, "/dev/gpiochip4")
    for bad in ("rx=4", "tonypie", "rx=a,tx=1", "rx=1,tx=2,pin=3"):
        with pytest.raises(ValueError, match=f"'{bad}' is not a preset .* nor rx=N,tx=N"):
            parse_direction(bad)
    with pytest.raises(ValueError, match="'rx=4,tx=4': rx and tx must be two different lines"):
        parse_direction("rx=4,tx=4")
    assert set(PRESETS) >= {"tonypi", "spiderpi", "armpi-pro", "jethexa", "ainex"}


# Device-tree compatible strings of each board, and the lines NVIDIA's Jetson.GPIO gives for
# header pins 11/13 (BCM 17/27, jethexa) and 35/37 (BCM 19/26, ainex) (gpio_pin_data.py).
JETSON_NANO = ["nvidia,p3449-0000-b00+p3448-0000-b00", "nvidia,jetson-nano", "nvidia,tegra210"]
ORIN_NANO = ["nvidia,p3768-0000+p3767-0005-super", "nvidia,p3767-0005", "nvidia,tegra234"]
AGX_ORIN = ["nvidia,p3737-0000+p3701-0005", "nvidia,p3701-0005", "nvidia,tegra234"]
RASPBERRY_PI = ["raspberrypi,4-model-b", "brcm,bcm2711"]


@pytest.mark.parametrize(
    ("preset", "compatibles", "expected"),
    [
        ("jethexa", JETSON_NANO, DirectionPins(rx=50, tx=14, chip="tegra-gpio")),
        ("ainex", JETSON_NANO, DirectionPins(rx=76, tx=12, chip="tegra-gpio")),
        ("jethexa", ORIN_NANO, DirectionPins(rx=112, tx=122, chip="tegra234-gpio")),
        ("ainex", ORIN_NANO, DirectionPins(rx=53, tx=124, chip="tegra234-gpio")),
        ("jethexa", AGX_ORIN, DirectionPins(rx=112, tx=108, chip="tegra234-gpio")),
        ("ainex", RASPBERRY_PI, DirectionPins(rx=19, tx=26)),  # a Pi: BCM = gpiochip0 offsets
        ("tonypi", [], DirectionPins(rx=4, tx=27)),  # no device tree (a PC)
        ("rx=5,tx=6,chip=tegra-gpio", JETSON_NANO, DirectionPins(5, 6, "tegra-gpio")),
    ],
)
def test_presets_resolve_to_the_jetson_models_lines(preset, compatibles, expected):
    assert board_pins(preset, compatibles) == expected


def test_a_preset_on_an_unknown_jetson_is_refused_naming_the_header_pins():
    unknown = ["nvidia,p9999-0000", "nvidia,tegra999"]
    with pytest.raises(ChoreoError) as error:
        board_pins("jethexa", unknown)
    message = str(error.value)
    assert "header pins 11 (RX_CON, BCM 17) and 13 (TX_CON, BCM 27)" in message
    assert "--direction rx=N,tx=N,chip=CHIP" in message and "\n" not in message


def test_a_preset_whose_lines_are_on_two_chips_is_refused():
    with pytest.raises(
        ChoreoError, match=r"line 53 of tegra234-gpio and line 3 of tegra234-gpio-aon"
    ):
        board_pins("ainex", AGX_ORIN)


def test_a_preset_refused_on_this_computer_is_one_line_from_servobus(monkeypatch):
    from choreo.bus.transports import jetson

    monkeypatch.setattr(jetson, "read_compatibles", lambda: ["nvidia,p9999-0000"])
    with pytest.raises(ChoreoError, match="no pin table"):
        ServoBus("sim://?ids=1-3&clock=virtual", direction="jethexa")


def test_direction_without_gpiod_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "gpiod", None)  # as if not installed
    with pytest.raises(ChoreoError, match=r"pip install 'choreo\[pi\]'"):
        ServoBus("sim://?ids=1-3&clock=virtual", direction="tonypi")


def test_gpiod_is_imported_only_when_direction_control_is_used():
    code = (
        "import sys; from choreo.bus.servo_bus import ServoBus; from choreo.cli import main; "
        "ServoBus('sim://?ids=1&clock=virtual').read_position(1); "
        "assert 'gpiod' not in sys.modules and 'hid' not in sys.modules, 'imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_direction_on_the_command_line_and_in_robot_yaml(tmp_path, capsys, monkeypatch):
    from choreo.cli import main

    with pytest.raises(SystemExit) as usage:
        main(["scan", "--direction", "rx=4", "--port", "sim://?ids=1"])
    assert usage.value.code == 2
    assert "rx=N,tx=N" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "gpiod", None)
    assert main(["scan", "--direction", "tonypi", "--port", "sim://?ids=1", "--ids", "1"]) == 1
    assert "pip install 'choreo[pi]'" in capsys.readouterr().err
    with pytest.raises(ChoreoError, match="direction control is for the raw bus"):
        ServoBus("rrc:///dev/ttyAMA0", direction="tonypi")


def test_robot_yaml_bus_direction(tmp_path):
    import shutil

    from choreo.errors import SourceError
    from choreo.robot.robot_file import load_robot

    folder = tmp_path / "arm6"
    shutil.copytree("models/arm6", folder)
    text = (folder / "robot.yaml").read_text()
    (folder / "robot.yaml").write_text(text + "bus:\n  port: /dev/ttyAMA0\n  direction: ainex\n")
    assert load_robot(folder / "robot.yaml").bus.direction == "ainex"
    (folder / "robot.yaml").write_text(text + "bus:\n  direction: rx=4\n")
    with pytest.raises(SourceError, match=r"robot.yaml:\d+:\d+: bus: direction: 'rx=4' is not a"):
        load_robot(folder / "robot.yaml")


def test_a_chip_label_is_found_among_the_gpio_chips(tmp_path, monkeypatch):
    from choreo.bus.transports import direction

    class FakeChip:
        labels = {"gpiochip0": "tegra-gpio", "gpiochip1": "tegra-gpio-aon"}

        def __init__(self, path):
            self.label = self.labels[path.rsplit("/", 1)[1]]

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            pass

        def get_info(self):
            return self

    class FakeGpiod:
        Chip = FakeChip

    for name in FakeChip.labels:
        (tmp_path / name).touch()
    monkeypatch.setattr(direction, "Path", lambda _: tmp_path)
    assert direction.chip_path(FakeGpiod, "tegra-gpio-aon") == str(tmp_path / "gpiochip1")
    assert direction.chip_path(FakeGpiod, "/dev/gpiochip4") == "/dev/gpiochip4"
    with pytest.raises(ChoreoError, match=r"no GPIO chip labelled 'tegra234-gpio'.*gpiodetect"):
        direction.chip_path(FakeGpiod, "tegra234-gpio")


@pytest.mark.parametrize("status_register", [True, False])
def test_the_transmitter_empty_bit_holds_the_turnaround_when_bytes_leave_late(status_register):
    # A UART 20 % slower than its nominal baud rate: the computed end comes before the last
    # stop bit. The line-status bit keeps transmit on until it has left; the sum alone cuts the
    # request's last byte off and the servo never answers.
    emulator = BusEmulator(range(1, 4), clock=VirtualClock())
    emulator.host_byte_time_s = 1.2 * 10 / 115200
    lines = FakeDirectionLines(emulator, drain_late_s=0.004)
    sim = SimSerial.from_emulator(emulator, timeout=0.05, baudrate=115200)
    port = sim if status_register else NoStatusRegister(sim)
    with ServoBus(DirectionSerial(port, lines, clock=emulator.clock), retries=0) as bus:
        if status_register:
            assert bus.read_position(2) == 500
        else:
            with pytest.raises(BusTimeoutError):
                bus.read_position(2)
            assert not emulator.log.packets  # the request never arrived whole
