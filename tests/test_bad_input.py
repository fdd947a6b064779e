"""Bad input a new user hit (issue 12): each gets one clear line and exit 1 or 2, nothing lost.

Each test names the exact line a user sees and the exit code.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from choreo.cli import main

REPO = Path(__file__).resolve().parents[1]
WAVE = REPO / "motions" / "arm6" / "wave.yaml"


def motion_file(tmp_path: Path, keyframes: str, *, name: str = "m.yaml", head: str = "") -> Path:
    path = tmp_path / name
    path.write_text(f"name: m\nrobot: arm6\n{head}keyframes:\n  - pose: home\n{keyframes}")
    return path


def error_line(capsys) -> str:
    """The one line on stderr (asserting there is exactly one)."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.rstrip("\n")


# --- usage errors: one UsageError, exit 2 --------------------------------------------------------
def test_a_usage_error_raised_by_a_handler_is_one_line_and_exit_2(capsys):
    assert main(["play", str(WAVE), "--exit-pose", "nope"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --exit-pose 'nope' is not a pose of arm6; poses: home, rest, ready"
    )


def test_usage_error_is_part_of_the_one_error_tree():
    from choreo.errors import ChoreoError, UsageError

    assert issubclass(UsageError, ChoreoError)


def test_cli_modules_follow_one_pattern():
    names = sorted(p.stem for p in (REPO / "choreo" / "cli").glob("*.py"))
    commands = [n for n in names if n not in ("__init__", "arguments")]
    assert commands and all(n.endswith("_commands") for n in commands), commands


# --- tracebacks ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "timing, where, seconds",
    [("after: 20000", "5:5", "20000"), ("t: 1.0e+9", "5:5", "1e+09")],
)
def test_a_segment_longer_than_ruckig_can_plan_is_one_line(
    tmp_path, capsys, timing, where, seconds
):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    {timing}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:{where}: keyframe reached {seconds} s after leaving the one "
        "before; at most 300 s can be planned between two keyframes: hold the one before "
        "instead (hold: is not limited), or add keyframes in between"
    )


def test_a_tiny_speed_is_one_line(capsys):
    assert main(["plan", str(WAVE), "--speed", "0.0002"]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {WAVE}:8:5: keyframe reached 5000 s after leaving the one before "
        "(at speed 0.0002); at most 300 s can be planned between two keyframes: hold the one "
        "before instead (hold: is not limited), or add keyframes in between"
    )


def test_a_long_hold_is_not_limited(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 30}\n    after: 1\n    hold: 1000\n")
    assert main(["plan", str(path)]) == 0
    assert "1001.0" in capsys.readouterr().out


# --- messages ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "written, hint", [("1e12", "1.0e+12"), ("2.5E3", "2.5e+3"), ("7.e2", "7.0e+2")]
)
def test_a_yaml_1_1_exponent_read_as_text_gets_a_hint(tmp_path, capsys, written, hint):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    after: {written}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:6:12: after must be a number >= 0, got {written!r} "
        f"(YAML reads {written} as text: write {hint})"
    )


def test_every_unreachable_keyframe_is_reported_at_once(tmp_path, capsys):
    path = motion_file(
        tmp_path,
        "  - pose: {shoulder: 80}\n    t: 0.1\n"
        "  - pose: {shoulder: 0}\n    t: 0.3\n"
        "  - pose: {shoulder: 80}\n    after: 0.1\n",
    )
    assert main(["plan", str(path)]) == 1
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": keyframe cannot be reached")[0] for line in lines] == [
        f"choreo: error: {path}:5:5",
        f"{path}:7:5",
        f"{path}:9:5",
    ]
    # each fix, applied alone to the keyframes before, is enough: t >= 0.467 then t >= 0.933
    assert lines[0].endswith(
        "allow 0.467 s at the earliest; use t >= 0.467, a lower speed, or stretch"
    )
    assert lines[1].endswith(
        "allow 0.933 s at the earliest; use t >= 0.933, a lower speed, or stretch"
    )
    assert lines[2].endswith("use after >= 0.467, a lower speed, or stretch")


def test_servo_limits_name_the_options_the_user_typed(capsys):
    argv = ["servo", "limits", "--id", "1", "--min", "900", "--max", "100", "-y"]
    assert main([*argv, "--port", "sim://?clock=virtual"]) == 2
    assert error_line(capsys) == "choreo: error: --min 900 must be below --max 100"


def test_piping_into_head_exits_quietly():
    """`choreo plan ... | head -1`: no "[Errno 32] Broken pipe", exit 1 (output cut short).
    The reader is gone before the first write, as when head has had its lines."""
    for argv in (
        ["plan", str(WAVE)],
        ["play", str(WAVE), "--dry-run"],
        ["scan", "--ids", "1", "--port", "sim://?ids=1"],
    ):
        read_end, write_end = os.pipe()
        os.close(read_end)
        with os.fdopen(write_end, "wb") as closed_pipe:
            process = subprocess.run(
                [sys.executable, "-m", "choreo", *argv],
                cwd=REPO,
                stdout=closed_pipe,
                stderr=subprocess.PIPE,
                timeout=120,
            )
        assert (process.returncode, process.stderr.decode()) == (1, ""), argv


def usage_error_line(capsys, argv: list[str]) -> str:
    """argparse's refusal: exit 2, its usage, then one line saying what is wrong."""
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    return capsys.readouterr().err.splitlines()[-1]


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["scan", "--timeout-ms", "1e308"],
            "choreo scan: error: argument --timeout-ms: expected a number > 0 and <= 5000 ms, "
            "got '1e308'",
        ),
        (
            ["play", str(WAVE), "--health-timeout-ms", "1e308"],
            "choreo play: error: argument --health-timeout-ms: expected a number > 0 and "
            "<= 5000 ms, got '1e308'",
        ),
        (
            ["emulate", "--pty", "x", "--turnaround-ms", "1e308"],
            "choreo emulate: error: argument --turnaround-ms: expected a number in 0..1000 ms, "
            "got '1e308'",
        ),
        (
            ["scan", "--retries", "10"],
            "choreo scan: error: argument --retries: invalid choice: 10 (choose from 0, 1, 2, 3, "
            "4, 5, 6, 7, 8, 9)",
        ),
    ],
)
def test_timer_options_are_bounded(capsys, argv, line):
    assert usage_error_line(capsys, argv) == line


def test_robot_file_bus_ranges_equal_the_command_line(tmp_path, capsys):
    robot = tmp_path / "arm6" / "robot.yaml"
    robot.parent.mkdir()
    for source in (REPO / "models" / "arm6").iterdir():
        (robot.parent / source.name).write_bytes(source.read_bytes())
    text = robot.read_text().replace(
        "defaults:", "bus: {retries: 10, timeout_ms: 5001}\ndefaults:", 1
    )
    robot.write_text(text)
    line = next(n for n, t in enumerate(text.splitlines(), 1) if t.startswith("bus:"))
    assert main(["validate", str(robot)]) == 1
    assert capsys.readouterr().out.splitlines() == [
        f"{robot}:{line}:16: bus: retries must be in 0..9, got 10",
        f"{robot}:{line}:32: bus: timeout_ms must be in (0, 5000], got 5001",
    ]
