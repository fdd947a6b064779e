"""choreo scan as a user sees it: servos found, and IDs shared by several servos named."""

from __future__ import annotations

import json
import os

import pytest

from choreo.cli import main


def test_scan_lists_the_servos_that_answer(capsys):
    assert main(["scan", "--port", "sim://?ids=2-4&clock=virtual", "--ids", "0-8", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [s["servo_id"] for s in report["servos"]] == [2, 3, 4]
    assert report["garbled_ids"] == []


def test_scan_names_an_id_that_two_servos_share(capsys):
    assert main(["scan", "--port", "sim://?ids=1-3,3&clock=virtual", "--ids", "0-5"]) == 0
    out = capsys.readouterr().out
    assert "ID 3: replies garbled: several servos share this ID" in out
    assert "2 servo(s)" in out


def test_scan_with_nothing_on_the_bus_says_what_to_check(capsys):
    assert main(["scan", "--port", "sim://?ids=9&clock=virtual", "--ids", "0-5"]) == 1
    assert "no servo answered on IDs 0-5: check power" in capsys.readouterr().out


def _corrupt_the_first_reply_of(monkeypatch, servo_id):
    """Every sim:// bus opened from now on damages the first reply of ``servo_id``."""
    from choreo.emulator import ReplyFaults, protocol_sim

    build = protocol_sim.emulator_from_url

    def with_fault(url):
        emulator = build(url)
        emulator.servo(servo_id).reply_faults = ReplyFaults(corrupt_next=1)
        return emulator

    monkeypatch.setattr(protocol_sim, "emulator_from_url", with_fault)


def test_scan_honours_retries_so_one_damaged_reply_is_not_a_shared_id(monkeypatch, capsys):
    _corrupt_the_first_reply_of(monkeypatch, 3)
    port = ["--port", "sim://?ids=2-4&clock=virtual", "--ids", "0-5", "--json"]
    assert main(["scan", *port, "--retries", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [s["servo_id"] for s in report["servos"]] == [2, 3, 4]
    assert report["garbled_ids"] == []
    assert main(["scan", *port, "--retries", "0"]) == 0
    assert json.loads(capsys.readouterr().out)["garbled_ids"] == [3]


@pytest.mark.parametrize("terminal", [True, False])
def test_scan_shows_progress_on_stderr_only_on_a_terminal(terminal, capsys, monkeypatch):
    for name in ("FORCE_COLOR", "TTY_COMPATIBLE"):
        monkeypatch.delenv(name, raising=False)
    if terminal:
        monkeypatch.setenv("FORCE_COLOR", "1")  # rich treats stderr as a terminal
    assert main(["scan", "--port", "sim://?ids=1-3", "--ids", "0-9"]) == 0
    out, err = capsys.readouterr()
    assert "3 servo(s) on sim://?ids=1-3" in out and "scanning" not in out
    assert ("scanning ID" in err and "/10" in err) is terminal
    if not terminal:
        assert err == ""


def test_scan_through_a_board_names_no_baud_rate_of_the_raw_bus(capsys):
    assert main(["scan", "--port", "sim://?board=rrc&ids=9&clock=virtual", "--ids", "1-3"]) == 1
    assert capsys.readouterr().out == (
        "no servo answered on IDs 1-3: check power (the servos need their own supply), that the "
        "servos are plugged into the RRC board and the board is switched on\n"
    )


def test_a_folder_or_fifo_given_as_the_port_is_named_so(tmp_path, capsys):
    fifo = tmp_path / "ttyFAKE"
    os.mkfifo(fifo)
    hint = "list ports with `choreo ports`; `sim://` is the built-in emulator"
    for port, kind in ((tmp_path, "a folder"), (fifo, "a FIFO (named pipe)")):
        assert main(["scan", "--port", str(port), "--ids", "1"]) == 1
        assert capsys.readouterr().err == (
            f"choreo: error: cannot open {port}: it is {kind}, not a serial port; {hint}\n"
        )


def test_an_empty_port_is_a_usage_error_naming_valid_ports(capsys):
    with pytest.raises(SystemExit) as exited:
        main(["scan", "--port", "", "--ids", "1"])
    assert exited.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "choreo scan: error: argument --port: expected a port such as /dev/ttyUSB0, COM3 or "
        "sim:// (list them with `choreo ports`), got ''"
    )
