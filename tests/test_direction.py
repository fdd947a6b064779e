"""GPIO half-duplex direction control on a Pi/Jetson UART, against fake enable lines that lose
what a real HAT would lose: host bytes sent while transmit is off, replies while receive is off."""

from __future__ import annotations

import subprocess
import sys

import pytest

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports.direction import PRESETS, DirectionPins, DirectionSerial, parse_direction
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial
from choreo.emulator.direction_gate import FakeDirectionLines
from choreo.errors import BusTimeoutError, ChoreoError


def gated_bus(serial_class=DirectionSerial, *, echo: bool = False):
    emulator = BusEmulator(range(1, 4), clock=VirtualClock(), echo=echo)
    lines = FakeDirectionLines(emulator)
    port = serial_class(SimSerial.from_emulator(emulator, timeout=0.05), lines)
    return ServoBus(port, retries=0, echo="none"), emulator, lines


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


class NoDrain(DirectionSerial):
    """Switches to receive as soon as write() returns, before the bytes have left."""

    def write(self, data):
        self.lines.transmit()
        written = self._port.write(data)
        self.lines.receive()
        return written


class ListensLate(DirectionSerial):
    """Drains, but keeps transmitting until after the reply has come (never opens receive)."""

    def write(self, data):
        self.lines.transmit()
        written = self._port.write(data)
        self._port.flush()
        return written


@pytest.mark.parametrize("wrong", [NoDrain, ListensLate])
def test_a_wrong_toggle_order_loses_the_exchange(wrong):
    bus, emulator, _ = gated_bus(wrong)
    with bus, pytest.raises(BusTimeoutError):
        bus.read_position(2)
    if wrong is NoDrain:
        assert not emulator.log.packets  # the request never reached the servo
    else:
        assert emulator.log.replies  # the servo answered; the host never heard it


def test_presets_and_explicit_pins():
    assert parse_direction("tonypi") == DirectionPins(rx=4, tx=27)
    assert parse_direction("ainex") == DirectionPins(rx=19, tx=26)
    assert parse_direction("jethexa") == DirectionPins(rx=17, tx=27)
    assert parse_direction("rx=5,tx=6,chip=/dev/gpiochip4") == DirectionPins(5, 6, "/dev/gpiochip4")
    for bad in ("rx=4", "rx=4,tx=4", "tonypie", "rx=a,tx=1", "rx=1,tx=2,pin=3"):
        with pytest.raises(ValueError, match="bad direction"):
            parse_direction(bad)
    assert set(PRESETS) >= {"tonypi", "spiderpi", "armpi-pro", "jethexa", "ainex"}


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
    with pytest.raises(SourceError, match=r"robot.yaml:\d+:\d+: bus: direction: bad direction"):
        load_robot(folder / "robot.yaml")
