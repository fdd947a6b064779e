"""`choreo ports --probe`: what is behind a port, told by listening and reads only."""

from __future__ import annotations

import json

import pytest

from choreo.bus.ports import FoundPort, PortListing
from choreo.bus.probe import probe_port
from choreo.bus.protocol import Command
from choreo.cli import main
from choreo.emulator import protocol_sim

READS = {Command.ID_READ, Command.POS_READ}


@pytest.fixture
def emulators(monkeypatch):
    """Every emulator the probe opens, to look at what reached its servos."""
    opened = []

    def recording(url):
        emulator = original(url)
        opened.append(emulator)
        return emulator

    original = protocol_sim.emulator_from_url
    monkeypatch.setattr(protocol_sim, "emulator_from_url", recording)
    return opened


@pytest.mark.parametrize(
    ("url", "transport", "ids", "battery_mv"),
    [
        ("sim://?ids=1-3,9&clock=virtual", "raw LX bus", (1, 2, 3, 9), None),
        ("sim://?ids=5&clock=virtual", "raw LX bus", (5,), None),
        ("sim://?board=rrc&ids=2,4&clock=virtual", "RRC board", (2, 4), 7400),
        ("sim://?board=lobot&ids=1-6&clock=virtual", "LOBOT controller", (1, 2, 3, 4, 5, 6), 7400),
    ],
)
def test_probe_names_what_answers_and_sends_reads_only(emulators, url, transport, ids, battery_mv):
    found = probe_port(url)
    assert (found.transport, found.port_string, found.servo_ids) == (transport, url, ids)
    assert found.battery_mv == battery_mv
    packets = [p.packet.command for e in emulators for p in e.log.packets]
    assert packets and set(packets) <= READS  # what reached the servos: reads only
    for emulator in emulators:
        assert all(s.position_units == 500 for s in emulator.servos)  # nothing moved


def test_several_servos_answering_the_broadcast_still_tell_a_bus():
    found = probe_port("sim://?ids=1-3&clock=virtual")
    assert "several servos answered" in found.note


def test_a_port_where_nothing_answers_says_so():
    found = probe_port("loop://")  # only our own bytes come back
    assert (found.transport, found.port_string, found.servo_ids) == (None, None, None)
    assert "nothing answered" in found.note


def test_a_port_that_does_not_open_is_a_result_not_an_error():
    found = probe_port("/dev/choreo-no-such-port")
    assert found.transport is None and "no such port" in found.note


def test_ports_probe_on_the_command_line(capsys):
    raw, rrc = "sim://?ids=1&clock=virtual", "sim://?board=rrc&ids=3&clock=virtual"
    assert main(["ports", "--probe", raw, rrc]) == 0
    out = capsys.readouterr().out
    # quoted for the shell: pasted bare, & would run the command in the background
    assert f"{raw}  raw LX bus, servo IDs 1\n    --port '{raw}'\n" in out
    assert f"{rrc}  RRC board, supply 7.4 V, servo IDs 3\n    --port '{rrc}'\n" in out
    assert main(["ports", "--probe", rrc, "--json"]) == 0
    (entry,) = json.loads(capsys.readouterr().out)["probed"]
    assert entry["transport"] == "RRC board" and entry["servo_ids"] == [3]
    assert entry["port_string"] == rrc and entry["battery_mv"] == 7400


def test_ports_probe_without_ports_probes_every_listed_one(monkeypatch, capsys):
    from choreo.cli import ports_commands

    urls = ["sim://?board=rrc&ids=1&clock=virtual", "sim://?ids=2&clock=virtual"]
    listing = PortListing(tuple(FoundPort("serial", u, None, "", None, (u,)) for u in urls), None)
    monkeypatch.setattr(ports_commands, "list_ports", lambda: listing)
    assert main(["ports", "--probe", "--json"]) == 0
    probed = json.loads(capsys.readouterr().out)["probed"]
    assert [(p["device"], p["transport"]) for p in probed] == [
        (urls[0], "RRC board"),
        (urls[1], "raw LX bus"),
    ]


def test_a_lobot_board_without_bus_servos_is_named_with_the_learm_possibility(monkeypatch):
    original = protocol_sim.emulator_from_url

    def no_bus_servos(url):  # as a LeArm's LSC-6: it answers its battery, drives PWM servos
        emulator = original(url)
        for servo in emulator.servos:
            servo.connected = False
        return emulator

    monkeypatch.setattr(protocol_sim, "emulator_from_url", no_bus_servos)
    found = probe_port("sim://?board=lobot&clock=virtual")
    assert (found.transport, found.servo_ids, found.battery_mv) == ("LOBOT controller", (), 7400)
    assert "LeArm's LSC-6 board drives PWM servos" in found.note
