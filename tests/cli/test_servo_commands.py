"""choreo servo as a user runs it: the confirmation before a write, values checked against their
ranges, sim:// servos renumbered only alone."""

from __future__ import annotations

import io
import json

import pytest
from cli_helpers import error_line
from emulated import sent

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.cli import main, servo_commands
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection


def test_cli_asks_and_a_no_writes_nothing(cli_emulator, monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", Terminal("n\n"))
    assert main(["servo", "temp-limit", "--id", "2", "70"]) == 1
    out = capsys.readouterr().out
    assert "servo 2: temperature limit 85 °C → 70 °C" in out
    assert "write it to the servo? [y/N]" in out and "nothing written" in out
    assert sent(cli_emulator, Command.TEMP_MAX_LIMIT_WRITE) == []


def test_cli_asks_and_a_yes_writes(cli_emulator, monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", Terminal("y\n"))
    assert main(["servo", "led", "--id", "2", "off"]) == 0
    assert "written and verified" in capsys.readouterr().out
    assert cli_emulator.servo(2).eeprom.led_off == 1


def test_cli_without_a_terminal_or_yes_refuses(cli_emulator, monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", io.StringIO("y\n"))
    assert main(["servo", "limits", "--id", "1", "--min", "100", "--max", "900"]) == 1
    err = capsys.readouterr().err
    assert "stdin is not a terminal" in err and "--yes" in err
    assert sent(cli_emulator, Command.ANGLE_LIMIT_WRITE) == []


def test_cli_led_errors_by_name_with_yes(cli_emulator, capsys):
    assert main(["servo", "led-errors", "--id", "1", "stalled,voltage", "--yes"]) == 0
    assert (
        "faults that flash the LED over-temperature, voltage, stalled → voltage, stalled"
        in capsys.readouterr().out
    )
    assert cli_emulator.servo(1).eeprom.error_mask == 6


def test_cli_offset_adjust_and_save(cli_emulator, capsys):
    assert main(["servo", "offset", "adjust", "--id", "1", "--units", "-10"]) == 0
    assert main(["servo", "offset", "save", "--id", "1", "-y"]) == 0
    assert cli_emulator.servo(1).eeprom.offset_units == -10


def test_cli_move_load_unload_motor(cli_emulator, capsys):
    assert main(["servo", "move", "--id", "1", "--pos", "300", "--time-ms", "200"]) == 0
    cli_emulator.clock.advance(0.5)
    assert cli_emulator.servo(1).position_units == pytest.approx(300)
    assert main(["servo", "unload", "--id", "1"]) == 0
    assert not cli_emulator.servo(1).loaded
    assert main(["servo", "load", "--id", "1"]) == 0
    assert cli_emulator.servo(1).loaded
    assert main(["servo", "motor", "--id", "1", "--speed", "200"]) == 0
    assert cli_emulator.servo(1).motor_mode
    assert main(["servo", "motor", "--id", "1", "--stop"]) == 0
    assert not cli_emulator.servo(1).motor_mode


@pytest.mark.parametrize(
    "argv, words",
    [
        (
            ["temp-limit", "--id", "1", "120"],
            "temperature limit must be a whole number in 50..100 °C",
        ),
        (
            ["move", "--id", "1", "--pos", "1200"],
            "position must be a whole number in 0..1000 units",
        ),
        (
            ["motor", "--id", "1", "--speed", "-2000"],
            "motor speed must be a whole number in -1000..1000",
        ),
        (["vin-limits", "--id", "1", "--min", "3000", "--max", "9000"], "4500..14000 mV"),
        (["set-id", "254"], "a servo ID is a whole number 0-253"),
        (["led-errors", "--id", "1", "hot"], "unknown fault 'hot'"),
    ],
)
def test_cli_bad_values_are_usage_errors_with_the_range(argv, words, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["servo", *argv, "--port", "sim://?clock=virtual"])
    assert exit_info.value.code == 2
    assert words in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, words",
    [
        (
            ["limits", "--id", "1", "--min", "900", "--max", "100", "-y"],
            "choreo: error: --min 900 must be below --max 100\n",
        ),
        (
            ["vin-limits", "--id", "1", "--min", "9000", "--max", "6000", "-y"],
            "choreo: error: --min 9000 mV must be below --max 6000 mV\n",
        ),
        (["offset", "adjust", "--id", "1", "--deg", "40"], "within -30.0..+30.0°"),
        (["move", "--id", "1", "--deg", "250"], "0..240°"),
    ],
)
def test_cli_values_the_codec_refuses_are_one_line(argv, words, capsys):
    assert main(["servo", *argv, "--port", "sim://?clock=virtual"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("choreo: error: ") and words in err


def test_cli_set_id_on_a_sim_url_renumbers_the_lone_servo(tmp_path, capsys):
    state = tmp_path / "servos.json"
    assert (
        main(
            ["servo", "set-id", "5", "--yes", "--port", f"sim://?ids=1&clock=virtual&state={state}"]
        )
        == 0
    )
    assert "servo ID 1 → 5 (the only servo on the bus)" in capsys.readouterr().out
    saved = json.loads(state.read_text())
    assert [s["eeprom"]["servo_id"] for s in saved["servos"]] == [5]


def test_cli_set_id_refuses_two_servos_on_a_sim_url(tmp_path, capsys):
    state = tmp_path / "servos.json"
    assert (
        main(
            [
                "servo",
                "set-id",
                "5",
                "--yes",
                "--port",
                f"sim://?ids=1-2&clock=virtual&state={state}",
            ]
        )
        == 1
    )
    assert "several servos answered" in capsys.readouterr().err
    assert not state.exists()  # no EEPROM was written


def test_cli_temp_limit_on_a_sim_url_persists(tmp_path, capsys):
    state = tmp_path / "servos.json"
    assert (
        main(
            [
                "servo",
                "temp-limit",
                "--id",
                "3",
                "65",
                "-y",
                "--port",
                f"sim://?ids=1-6&clock=virtual&state={state}",
            ]
        )
        == 0
    )
    saved = json.loads(state.read_text())
    assert [s["eeprom"]["temp_max_c"] for s in saved["servos"]] == [85, 85, 65, 85, 85, 85]


def test_cli_info_still_works(capsys):
    assert main(["servo", "info", "--id", "2", "--json", "--port", "sim://?clock=virtual"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["servo_id"] == 2 and info["temp_limit_c"] == 85


def test_servo_limits_name_the_options_the_user_typed(capsys):
    argv = ["servo", "limits", "--id", "1", "--min", "900", "--max", "100", "-y"]
    assert main([*argv, "--port", "sim://?clock=virtual"]) == 2
    assert error_line(capsys) == "choreo: error: --min 900 must be below --max 100"


def test_cli_move_to_a_huge_angle_is_one_line_and_sends_nothing(cli_emulator, capsys):
    assert main(["servo", "move", "--id", "2", "--deg", "1e308", "--port", "sim://?ids=1-6"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --deg must be in 0..240° (0..1000 units), got 1e+308°"
    )
    assert sent(cli_emulator, Command.MOVE_TIME_WRITE) == []


def test_cli_offset_beyond_its_range_names_the_flag(cli_emulator, capsys):
    argv = ["servo", "offset", "adjust", "--id", "2", "--deg", "31", "--port", "sim://?ids=1-6"]
    assert main(argv) == 2
    assert error_line(capsys) == (
        "choreo: error: --deg must be within -30.0..+30.0° (-125..125 units), got 31°"
    )
    assert sent(cli_emulator, Command.ANGLE_OFFSET_ADJUST) == []


# --- through the CLI ---------------------------------------------------------------------------
class Terminal(io.StringIO):
    """stdin as a terminal where the user types ``text``."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def cli_emulator(monkeypatch):
    """`choreo servo ...` on an in-process emulator (servos 1 and 2), so tests can inspect it."""
    emulator = BusEmulator((1, 2), clock=VirtualClock())
    monkeypatch.setattr(servo_commands, "open_bus", lambda args: ServoBus(connection(emulator)))
    return emulator
