"""choreo.cli: main() turns every error into one line and an exit code (2 for usage, 1 for the
rest, 130 for a signal), and a closed pipe into a quiet exit."""

from __future__ import annotations

import importlib
import io
import json
import os
import signal
import subprocess
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from cli_helpers import REPO, WAVE, error_line

from choreo.cli import command_line, main
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
    commands = [n for n in names if n not in ("__init__", "command_line", "arguments")]
    assert commands and all(n.endswith("_commands") for n in commands), commands


@contextmanager
def stdout_into_a_closed_pipe(monkeypatch) -> Iterator[None]:
    """sys.stdout a pipe whose reader is gone (as when head has had its lines), opened as Python
    opens a process's stdout; closed after."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    with open(write_end, "w") as closed_pipe:
        monkeypatch.setattr(sys, "stdout", closed_pipe)
        yield
        monkeypatch.undo()


def exit_status(argv: list[str]) -> int | str | None:
    """The exit status of `choreo *argv` run here: what main returns, or the code of a
    SystemExit it let through (rich's console ends so on a broken pipe)."""
    try:
        return main(argv)
    except SystemExit as exited:
        return exited.code


def test_piping_into_head_exits_quietly(capsys, monkeypatch):
    """`choreo plan ... | head -1`: no "[Errno 32] Broken pipe", exit 1 (output cut short).
    The reader is gone before the first write, as when head has had its lines. In a process of
    its own once (its interpreter's last flush must find nothing left to fail on), then each
    command's way of writing here (a process costs 0.5 s of CPU to start)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    with os.fdopen(write_end, "wb") as closed_pipe:
        process = subprocess.run(
            [sys.executable, "-m", "choreo", "plan", str(WAVE)],
            cwd=REPO,
            stdout=closed_pipe,
            stderr=subprocess.PIPE,
            timeout=120,
        )
    assert (process.returncode, process.stderr.decode()) == (1, "")
    for argv in (
        ["plan", str(WAVE)],
        ["play", str(WAVE), "--dry-run"],
        ["scan", "--ids", "1", "--port", "sim://?ids=1"],
    ):
        with stdout_into_a_closed_pipe(monkeypatch):
            code = exit_status(argv)
        assert (code, capsys.readouterr().err) == (1, ""), argv


def test_a_closed_stdout_does_not_lose_the_play_report(tmp_path, capsys, monkeypatch):
    report = tmp_path / "play.json"
    argv = ["play", str(WAVE), "--port", "sim://?ids=1-6&clock=virtual", "--report", str(report)]
    with stdout_into_a_closed_pipe(monkeypatch):
        code = exit_status(argv)
    assert code == 1 and "Traceback" not in capsys.readouterr().err
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


def ascii_choreo(*argv: str) -> subprocess.CompletedProcess:
    """``choreo *argv`` whose output can only be ASCII (a C locale, an ASCII pipe)."""
    return subprocess.run(
        [sys.executable, "-m", "choreo", *argv],
        cwd=REPO,
        env={**os.environ, "LC_ALL": "C", "PYTHONIOENCODING": "ascii"},
        capture_output=True,
        timeout=120,
    )


def ascii_main(monkeypatch, *argv: str) -> tuple[int, bytes, bytes]:
    """main(argv) here, its stdout and stderr ASCII text streams as in the process above
    (strict, as Python makes them): exit code, and the bytes written to each."""
    written = {"stdout": io.BytesIO(), "stderr": io.BytesIO()}
    for name, sink in written.items():
        monkeypatch.setattr(sys, name, io.TextIOWrapper(sink, encoding="ascii", write_through=True))
    code = main(list(argv))
    return code, written["stdout"].getvalue(), written["stderr"].getvalue()


def test_what_the_output_cannot_encode_is_escaped_not_an_error(tmp_path, monkeypatch):
    robots = ascii_choreo("robots", "arm6")  # in a process: its streams as Python made them
    assert (robots.returncode, robots.stderr) == (0, b"")
    assert b"| min \\xb0 | max \\xb0 |" in robots.stdout  # degrees
    motion = tmp_path / "wävé.yaml"
    motion.write_text(WAVE.read_text())
    code, out, err = ascii_main(monkeypatch, "validate", str(motion))
    assert (code, err) == (0, b"")
    assert out == f"{tmp_path}/w\\xe4v\\xe9.yaml: ok\n".encode()
    code, out, err = ascii_main(monkeypatch, "beats", str(tmp_path / "nö.ogg"))
    assert (code, out) == (1, b"")
    assert err == f"choreo: error: {tmp_path}/n\\xf6.ogg does not exist\n".encode()


# `choreo *argv` that sends itself the signal SIGNAL as it starts importing MODULE: a signal that
# comes while the command's modules load, at a known point and no timing
SIGNALLED_WHILE_IMPORTING = """
import os, sys
module, signum, *argv = sys.argv[1:]

class Signaller:
    def find_spec(self, name, path, target=None):
        if name == module:
            os.kill(os.getpid(), int(signum))

sys.meta_path.insert(0, Signaller())
from choreo.cli import command_line, main
sys.exit(main(argv))
"""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
@pytest.mark.parametrize("command", [["play", "--dry-run"], ["preview", "--check"]])
def test_a_signal_while_the_modules_load_is_ctrl_c_without_a_traceback(command, signum):
    done = subprocess.run(
        [sys.executable, "-c", SIGNALLED_WHILE_IMPORTING, "choreo.plan.pipeline", str(signum)]
        + [command[0], str(WAVE), *command[1:]],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (done.returncode, done.stdout, done.stderr) == (130, "", "choreo: interrupted\n")


# `python -m choreo *argv` that sends itself Ctrl-C as it starts importing MODULE: before main()
# runs, while the command line itself loads
CTRL_C_AS_IT_STARTS = """
import os, runpy, signal, sys
module, *argv = sys.argv[1:]

class Signaller:
    def find_spec(self, name, path, target=None):
        if name == module:
            os.kill(os.getpid(), signal.SIGINT)

sys.meta_path.insert(0, Signaller())
sys.argv = ["choreo", *argv]
runpy.run_module("choreo", run_name="__main__")
"""


@pytest.mark.parametrize("module", ["choreo.cli.command_line", "choreo.core.collector", "argparse"])
def test_ctrl_c_while_the_command_line_itself_loads_is_exit_130_without_a_traceback(module):
    """The console script and ``python -m choreo`` import choreo.cli, whose program() loads the
    command line under its own Ctrl-C guard: no window before main() shows a traceback."""
    done = subprocess.run(
        [sys.executable, "-c", CTRL_C_AS_IT_STARTS, module, "play", str(WAVE), "--dry-run"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (done.returncode, done.stdout, done.stderr) == (130, "", "choreo: interrupted\n")


def test_a_compiled_module_whose_import_ctrl_c_stopped_is_an_interruption_not_a_bug(
    monkeypatch, capsys
):
    """mujoco's initialisation, interrupted, fails as ImportError('initialization failed')
    caused by the KeyboardInterrupt: Ctrl-C, exit 130, not an internal error."""
    from choreo.cli import bus_commands

    def import_interrupted(bus, ids):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as interrupt:
            raise ImportError("initialization failed") from interrupt

    monkeypatch.setattr(bus_commands, "scan_with_progress", import_interrupted)
    assert main(["scan", "--ids", "1", "--port", "sim://?ids=1"]) == 130
    assert capsys.readouterr().err == "choreo: interrupted\n"


def test_the_package_s_names_are_the_command_line_s_and_nothing_else():
    import choreo.cli

    assert choreo.cli.main is command_line.main
    assert choreo.cli.flag_of("exit_pose") == "--exit-pose"
    with pytest.raises(AttributeError, match="module 'choreo.cli' has no attribute 'nope'"):
        choreo.cli.nope  # noqa: B018


@pytest.mark.parametrize(
    "command, argv",
    [
        ("servo offset adjust", ["servo", "offset", "adjust", "--id", "1", "--deg", "2", "--yes"]),
        ("play", ["play", str(WAVE), "--yes"]),
    ],
)
def test_an_argument_a_command_does_not_know_gets_that_command_s_usage(command, argv, capsys):
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"usage: choreo {command} [-h]")
    assert err.splitlines()[-1] == f"choreo {command}: error: unrecognized arguments: --yes"


def test_the_collector_passes_over_the_loaded_modules_only_while_a_command_runs(
    tmp_path, capsys, monkeypatch
):
    import gc

    import choreo.cli.plan_commands as plan_commands

    seen = []
    compile_motion = plan_commands.compile_motion

    def watched(*args, **kwargs):
        seen.append((gc.isenabled(), gc.get_freeze_count() > 0))
        return compile_motion(*args, **kwargs)

    monkeypatch.setattr(plan_commands, "compile_motion", watched)
    assert main(["plan", str(WAVE)]) == 0
    assert seen == [(True, True)]  # the modules set aside, the collector running
    missing = tmp_path / "missing.yaml"
    assert main(["plan", str(missing)]) == 1  # a command that fails gives them back too
    capsys.readouterr()
    assert (gc.isenabled(), gc.get_freeze_count()) == (True, 0)


def test_the_modules_a_handler_imports_load_with_the_command_s_modules(monkeypatch, capsys):
    """A handler's own imports (``loads``) happen before it runs, as its command module's do:
    the collector paused, and a SIGTERM taken as Ctrl-C once they are loaded, not the end of
    the process (a performer loading its planner once exited by the signal, without a word)."""
    import gc
    import importlib

    real_import = importlib.import_module
    seen = []

    def watched(name: str, package: str | None = None):
        if name == "choreo.show.performer":
            seen.append((gc.isenabled(), signal.getsignal(signal.SIGTERM) is signal.SIG_DFL))
        return real_import(name, package)

    monkeypatch.setattr(importlib, "import_module", watched)
    assert main(["perform", "--port", "/dev/null", "--listen", "tcp/127.0.0.1:0"]) == 1
    assert "cannot open /dev/null" in capsys.readouterr().err  # refused in the handler, after
    assert seen == [(False, False)]


def test_a_handler_s_own_imports_are_the_modules_it_loads_first():
    """What a handler marked with ``loads`` imports in its body, it names there: otherwise that
    import runs with the collector on and a SIGTERM not yet taken as Ctrl-C. (Its helpers may
    import more only when needed, as plan's report table imports rich only for the table.)"""
    import ast
    import inspect
    import textwrap

    from choreo.cli.arguments import handler_modules

    marked = 0
    for name in sorted(set(command_line.COMMAND_MODULES.values())):
        module = importlib.import_module(f"choreo.cli.{name}")
        for handler in [f for f in vars(module).values() if callable(f) and handler_modules(f)]:
            marked += 1
            tree = ast.parse(textwrap.dedent(inspect.getsource(handler)))
            imported = {
                node.module
                for node in ast.walk(tree)
                if isinstance(node, ast.ImportFrom) and node.module
            }
            missing = imported - set(handler_modules(handler))
            assert not missing, (handler.__qualname__, sorted(missing))
    assert marked >= 2  # choreo perform's and choreo show's, at least


def test_numpy_gets_one_blas_thread_unless_the_user_chose_a_number(monkeypatch):
    from choreo.cli import one_blas_thread

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    one_blas_thread()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "4")
    one_blas_thread()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "4"


def test_the_program_leaves_what_is_left_at_its_exit_set_aside_from_the_collector(
    monkeypatch, capsys
):
    import gc

    from choreo.cli import program

    monkeypatch.setattr(sys, "argv", ["choreo", "robots"])
    try:
        assert program() == 0
        assert gc.get_freeze_count() > 0  # the interpreter's last collection passes over them
    finally:
        gc.unfreeze()
    assert "arm6" in capsys.readouterr().out
