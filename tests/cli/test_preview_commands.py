"""choreo preview as a user runs it: exit codes, the JSON report, usage errors, the viewer without a
display, and rendering to a file."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from cli_helpers import PREVIEW_MOTIONS, REPO, usage_error_line
from PIL import Image

from choreo.cli import main

FINE = PREVIEW_MOTIONS / "fine.yaml"


# --- the command line --------------------------------------------------------------------------
def test_preview_check_exits_1_on_errors_and_0_when_clean(capsys):
    assert main(["preview", "--check", str(PREVIEW_MOTIONS / "fine.yaml")]) == 0
    assert "0 error(s), 0 warning(s)" in capsys.readouterr().out
    assert main(["preview", "--check", str(PREVIEW_MOTIONS / "collide.yaml")]) == 1
    out = capsys.readouterr().out
    assert "error: self-collision: base hits forearm" in out and "1 error(s)" in out


def test_preview_report_writes_json(tmp_path, capsys):
    report = tmp_path / "report.json"
    assert main(["preview", str(PREVIEW_MOTIONS / "fine.yaml"), "--report", str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["ok"] is True and data["robot"] == "arm3" and len(data["joints"]) == 3


@pytest.mark.parametrize(
    "argv, message",
    [
        (["-o", "out.avi"], "must end in .mp4, .gif, .png"),
        (["-o", "out.mp4", "--size", "161x120"], "mp4 needs an even width and height"),
        (["--check", "-o", "out.png"], "--check runs the checks only"),
    ],
)
def test_preview_usage_errors_exit_2(argv, message, capsys):
    assert main(["preview", str(PREVIEW_MOTIONS / "fine.yaml"), *argv]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--near-miss", "--fall-height"])
def test_a_fraction_flag_takes_at_most_all_of_it(flag, capsys):
    """A share of the stall torque, of the start height: 1.5 of it would flag every step."""
    assert usage_error_line(capsys, ["preview", str(FINE), "--check", flag, "1.5"]) == (
        f"choreo preview: error: argument {flag}: expected a fraction in (0, 1], got '1.5'"
    )


def test_a_huge_speed_is_refused_as_typed_not_in_hundreds_of_digits(capsys):
    assert usage_error_line(capsys, ["preview", str(FINE), "--check", "--speed", "1e308"]) == (
        "choreo preview: error: argument --speed: expected a number >= 0.01 and <= 100, got '1e308'"
    )


def test_check_renders_nothing_so_a_mujoco_gl_naming_no_back_end_does_not_matter():
    """mujoco refuses an unknown MUJOCO_GL as it is imported: a process of its own, where it
    has not been imported yet."""
    done = subprocess.run(
        [sys.executable, "-m", "choreo", "preview", str(FINE), "--check"],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), "MUJOCO_GL": "bogus"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert "0 error(s)" in done.stdout


def test_preview_check_says_where_as_validate_does(capsys):
    collide = PREVIEW_MOTIONS / "collide.yaml"
    assert main(["preview", str(collide), "--check"]) == 1
    out = capsys.readouterr().out.splitlines()
    finding = next(line for line in out if ": error: " in line)
    assert finding.startswith(f"{collide}:6:5: error: self-collision: base hits forearm")
    assert main(["validate", str(collide)]) == 1
    validated = capsys.readouterr().out.splitlines()[0]
    assert validated == finding.replace(": error: ", ": preview: ", 1)


def test_preview_renders_a_contact_sheet_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    assert (
        main(
            [
                "preview",
                str(PREVIEW_MOTIONS / "fine.yaml"),
                "-o",
                str(out),
                "--size",
                "128x96",
                "--frames",
                "4",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert f"wrote {out} (4 frames of 128x96, rendered with" in printed
    assert Image.open(out).size == (4 * 128 + 3 * 4, 96)


def test_rendering_a_motion_with_errors_still_writes_the_file_and_says_why(tmp_path, capsys):
    out = tmp_path / "collide.mp4"
    argv = [
        "preview",
        str(PREVIEW_MOTIONS / "collide.yaml"),
        "-o",
        str(out),
        "--size",
        "64x48",
        "--fps",
        "5",
    ]
    assert main(argv) == 0
    assert "error: self-collision" in capsys.readouterr().out
    assert out.stat().st_size > 0


def test_preview_keeps_an_existing_output_unless_told_to_overwrite(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    out.write_bytes(b"an earlier sheet")
    argv = [
        "preview",
        str(PREVIEW_MOTIONS / "fine.yaml"),
        "-o",
        str(out),
        "--size",
        "64x48",
        "--frames",
        "2",
    ]
    assert main(argv) == 1
    captured = capsys.readouterr()
    assert captured.err == (
        f"choreo: error: {out} exists: choose another file, or allow replacing it (--overwrite)\n"
    )
    assert captured.out == "" and out.read_bytes() == b"an earlier sheet"  # refused before work
    assert main([*argv, "--overwrite"]) == 0
    assert Image.open(out).size == (2 * 64 + 4, 48)


@pytest.mark.parametrize(
    "output, option, message",
    [
        ("v.mp4", ["--fps", "100000"], "--fps 100000: an mp4 has at most 120 frames per second"),
        ("v.gif", ["--fps", "1000"], "--fps 1000: a GIF plays 100/N frames per second"),
        ("v.gif", ["--fps", "30"], "--fps 30: a GIF plays 100/N frames per second"),
    ],
)
def test_preview_refuses_a_frame_rate_the_file_cannot_play(
    tmp_path, capsys, output, option, message
):
    assert main(["preview", str(FINE), "-o", str(tmp_path / output), *option]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"choreo: error: {message}") and captured.out == ""


def test_preview_bounds_the_frames_of_a_contact_sheet(tmp_path, capsys):
    with pytest.raises(SystemExit) as exited:
        main(
            [
                "preview",
                str(PREVIEW_MOTIONS / "fine.yaml"),
                "-o",
                str(tmp_path / "s.png"),
                "--frames",
                "100000",
            ]
        )
    assert exited.value.code == 2
    assert (
        capsys.readouterr()
        .err.splitlines()[-1]
        .endswith("argument --frames: expected a whole number from 1 to 100, got '100000'")
    )


def test_a_gif_at_100_over_n_fps_has_exact_10_ms_delays(tmp_path):
    out = tmp_path / "fine.gif"
    argv = [
        "preview",
        str(PREVIEW_MOTIONS / "fine.yaml"),
        "-o",
        str(out),
        "--size",
        "32x24",
        "--fps",
        "33.33",
    ]
    assert main(argv) == 0
    with Image.open(out) as gif:
        durations = set()
        for k in range(gif.n_frames):
            gif.seek(k)
            durations.add(gif.info["duration"] % 30)  # merged identical frames: whole 30 ms
    assert durations == {0}
