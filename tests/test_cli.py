"""choreo.cli: main() turns every error into one line and an exit code (2 for usage, 1 for the
rest, 130 for a signal), and a closed pipe into a quiet exit."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

from cli_helpers import REPO, WAVE, error_line

from choreo.cli import main
from choreo.errors import SourceError


def test_a_usage_error_raised_by_a_handler_is_one_line_and_exit_2(capsys):
    assert main(["play", str(WAVE), "--exit-pose", "nope"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --exit-pose nope is used only with --exit pose (now --exit hold): add "
        "--exit pose, or drop --exit-pose"
    )
    assert main(["play", str(WAVE), "--exit", "pose", "--exit-pose", "nope"]) == 2
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


def test_a_closed_stdout_does_not_lose_the_play_report(tmp_path):
    report = tmp_path / "play.json"
    read_end, write_end = os.pipe()
    os.close(read_end)
    argv = ["play", str(WAVE), "--port", "sim://?ids=1-6&clock=virtual", "--report", str(report)]
    with os.fdopen(write_end, "wb") as closed_pipe:
        done = subprocess.run(
            [sys.executable, "-m", "choreo", *argv],
            cwd=REPO,
            stdout=closed_pipe,
            stderr=subprocess.PIPE,
            timeout=120,
        )
    assert done.returncode == 1 and b"Traceback" not in done.stderr
    assert json.loads(report.read_text())["outcome"] == "completed"


def test_python_warnings_reach_the_terminal_only_with_verbose(tmp_path, capsys, monkeypatch):
    import choreo.cli.plan_commands as plan_commands

    def warn_and_fail(args):
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        raise SourceError("m.yaml:1:1: refused")

    def show_on_stderr(message, category, filename, lineno, file=None, line=None):
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    monkeypatch.setattr(plan_commands, "run_plan", warn_and_fail)
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # shown on stderr, as a plain python run shows them
        warnings.showwarning = show_on_stderr
        assert main(["plan", "m.yaml"]) == 1
        assert capsys.readouterr().err == "choreo: error: m.yaml:1:1: refused\n"
        assert main(["-v", "plan", "m.yaml"]) == 1
    assert "RuntimeWarning: overflow encountered in multiply" in capsys.readouterr().err
