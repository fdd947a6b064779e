"""The package as users get it: its version, its type hints, and a start-up that stays light."""

import ast
import functools
import importlib
import os
import subprocess
import sys
import tomllib
import types
from pathlib import Path

import pytest
from paths import REPO

import choreo

ROOT = REPO


def run_choreo(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "choreo", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_version_prints_the_package_version():
    result = run_choreo("--version")
    assert (result.returncode, result.stdout, result.stderr) == (
        0,
        f"choreo {choreo.__version__}\n",
        "",
    )


def test_the_version_is_written_once_and_the_type_hints_ship():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"]
    assert "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "choreo.__version__"}
    assert "py.typed" in project["tool"]["setuptools"]["package-data"]["choreo"]
    assert (ROOT / "choreo" / "py.typed").is_file()


HEAVY_MODULES = ("mujoco", "matplotlib")
# Runs bus-only commands in one process, then names every heavy module they pulled in.
BUS_ONLY_COMMANDS = """
import contextlib, io, sys
import choreo.cli
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    codes = [
        choreo.cli.main(["scan", "--ids", "1-2"]),
        choreo.cli.main(["servo", "info", "--id", "1"]),
    ]
    for args in (["emulate", "--help"], ["scan", "--help"]):
        try:
            choreo.cli.main(args)
        except SystemExit as done:
            codes.append(done.code)
print(codes, sorted(m for m in {HEAVY} if m in sys.modules))
""".replace("{HEAVY}", repr(HEAVY_MODULES))


def test_bus_only_commands_never_import_mujoco_or_matplotlib():
    result = subprocess.run(
        [sys.executable, "-c", BUS_ONLY_COMMANDS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (result.returncode, result.stdout) == (0, "[0, 0, 0, 0] []\n"), result.stderr


# What `choreo scan --help` loads: the modules of the other commands, rich and numpy wait for a
# command that uses them.
SCAN_HELP_IMPORTS = """
import contextlib, io, sys
import choreo.cli
with contextlib.redirect_stdout(io.StringIO()):
    try:
        choreo.cli.main(["scan", "--help"])
    except SystemExit:
        pass
print(sorted(m for m in sys.modules if m.startswith("choreo.cli.")),
      sorted(m for m in ("numpy", "rich", "yaml", "choreo.robot") if m in sys.modules))
"""


def test_scan_help_imports_only_its_own_command_module():
    result = subprocess.run(
        [sys.executable, "-c", SCAN_HELP_IMPORTS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    loaded = "['choreo.cli.arguments', 'choreo.cli.bus_commands', 'choreo.cli.command_line'] []\n"
    assert result.stdout == loaded, result.stderr


def test_each_command_module_registers_the_commands_the_table_gives_it():
    import argparse
    import importlib

    from choreo.cli import COMMAND_MODULES

    for module_name in set(COMMAND_MODULES.values()):
        parser = argparse.ArgumentParser()
        subparsers = parser.add_subparsers()
        importlib.import_module(f"choreo.cli.{module_name}").register(subparsers)
        expected = sorted(c for c, m in COMMAND_MODULES.items() if m == module_name)
        assert sorted(subparsers.choices) == expected


def test_the_heavy_check_sees_mujoco_when_a_robot_is_loaded(tmp_path):
    """The probe above would notice: loading a robot checks its MuJoCo model (the first time:
    an empty cache remembers no check)."""
    probe = "import sys; from choreo.robot.robot_file import load_robot; load_robot('arm6'); "
    probe += "print('mujoco' in sys.modules)"
    result = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "CHOREO_CACHE_DIR": str(tmp_path)},
    )
    assert result.stdout == "True\n", result.stderr


def test_the_public_api_resolves_and_import_choreo_stays_light():
    # the import in a fresh process; the names resolved here (each loads its module: all of
    # them load mujoco, numpy and the rest, 0.6 s of CPU in a process of its own)
    probe = (
        "import sys, choreo; "
        "print(sorted(m for m in ('numpy', 'yaml', 'serial', 'ruckig') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.stdout == "[]\n", result.stderr
    assert [name for name in choreo.__all__ if not hasattr(choreo, name)] == []
    assert choreo.compile_motion.__module__ == "choreo.plan.pipeline"
    assert choreo.load_robot.__module__ == "choreo.robot.robot_file"


def test_the_public_names_are_listed_once_and_type_checkers_see_the_same():
    """``choreo.PUBLIC`` is the list; the imports type checkers read must name the same things
    from the same modules, and every error of the tree is exported."""
    tree = ast.parse((ROOT / "choreo" / "__init__.py").read_text())
    (guard,) = [n for n in tree.body if isinstance(n, ast.If)]  # if TYPE_CHECKING:
    seen = {
        (node.module, alias.name)
        for node in guard.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    listed = {(module, name) for module, names in choreo.PUBLIC.items() for name in names}
    assert seen == listed
    tree_errors = {
        name
        for name, value in vars(choreo.errors).items()
        if isinstance(value, type) and issubclass(value, choreo.ChoreoError)
    }
    assert tree_errors - set(choreo.__all__) == {"UsageError"}


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'compile'"):
        choreo.compile  # noqa: B018


@functools.cache  # each test file is asked about for every module in its folder
def modules_named_by(test_file: Path) -> set[str]:
    """The choreo modules a test file imports, as dotted names (``choreo.bus.servo_bus``); a name
    a package re-exports (``from choreo.preview import simulate_motion``) counts for the module
    that defines it."""
    named = set()
    for node in ast.walk(ast.parse(test_file.read_text())):
        if isinstance(node, ast.Import):
            named.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            named.add(node.module)
            for alias in node.names:
                named.add(defining_module(node.module, alias.name))
    return {name for name in named if name.startswith("choreo.")}


def defining_module(module: str, name: str) -> str:
    """Where ``from <module> import <name>`` really comes from."""
    if not module.startswith("choreo"):
        return module
    value = getattr(importlib.import_module(module), name, None)
    if isinstance(value, types.ModuleType):
        return value.__name__
    return getattr(value, "__module__", None) or f"{module}.{name}"


def test_every_module_is_tested_in_the_folder_that_mirrors_it():
    """tests/ mirrors choreo/: the tests of ``choreo/<folder>/<module>.py`` are in
    ``tests/<folder>/``, in ``test_<module>.py`` or in a test file there that imports the module
    (one file may test a few modules that work together, as tests/show/test_show.py does)."""
    package = Path(choreo.__file__).parent
    tests = Path(__file__).parent
    untested = []
    for module in sorted(package.rglob("*.py")):
        if module.name in ("__init__.py", "__main__.py"):
            continue
        folder = module.parent.relative_to(package)
        dotted = ".".join(("choreo", *folder.parts, module.stem))
        test_files = sorted((tests / folder).glob("test_*.py"))
        if (tests / folder / f"test_{module.stem}.py") not in test_files and not any(
            dotted in modules_named_by(test_file) for test_file in test_files
        ):
            untested.append(f"{module.relative_to(package.parent)}: no tests in tests/{folder}/")
    assert untested == []


def test_every_test_file_sits_in_a_folder_of_the_package():
    """A test folder with no package folder behind it would teach a layout that is not there."""
    package = Path(choreo.__file__).parent
    tests = Path(__file__).parent
    strays = [
        test_file.relative_to(tests).as_posix()
        for test_file in tests.rglob("test_*.py")
        if "data" not in test_file.relative_to(tests).parts
        and not (package / test_file.parent.relative_to(tests)).is_dir()
    ]
    assert strays == []


def test_a_bug_is_reported_as_one_line_exit_70_with_its_traceback_in_a_file(
    monkeypatch, capsys, tmp_path
):
    """An exception that is no ChoreoError (here a KeyError inside a command) is choreo's bug,
    not the user's mistake: not dressed as 'choreo: error:', its traceback kept."""
    from choreo.cli import bus_commands, main

    def broken(bus, ids):
        raise KeyError("oops")

    monkeypatch.setattr(bus_commands, "scan_with_progress", broken)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    assert main(["scan", "--ids", "1"]) == 70
    err = capsys.readouterr().err.splitlines()
    [trace] = tmp_path.glob("choreo-bug-*.txt")
    assert err[-1] == (
        f"choreo: internal error (a bug): KeyError: 'oops'; please report it with the traceback "
        f"(in {trace})"
    )
    assert 'raise KeyError("oops")' in trace.read_text()


def test_an_os_error_choreo_did_not_cause_is_a_user_error(monkeypatch, capsys):
    import errno

    from choreo.cli import bus_commands, main

    def disk_full(bus, ids):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(bus_commands, "scan_with_progress", disk_full)
    assert main(["scan", "--ids", "1"]) == 1
    assert capsys.readouterr().err.splitlines()[-1] == ("choreo: error: no space left on device")


def test_a_servo_in_motor_mode_is_refused_with_the_data_the_cli_turns_into_its_hint():
    from choreo.bus import servo_config
    from choreo.bus.protocol import Command
    from choreo.bus.servo_bus import ServoBus
    from choreo.cli import hint_for
    from choreo.errors import BusError

    with ServoBus("sim://?ids=2&clock=virtual") as bus:
        bus.set_motor_mode(2, 300)
        with pytest.raises(BusError) as caught:
            servo_config.move(bus, 2, 500, 100)
    error = caught.value
    assert str(error) == (
        "servo 2 is in motor mode and ignores moves: stop its motor first (stop_motor)"
    )
    assert (error.servo_id, error.command) == (2, Command.OR_MOTOR_MODE_READ)
    assert hint_for(error) == "stop its motor with `choreo servo motor --id 2 --stop`"
    assert hint_for(BusError("no servo answered")) is None


def test_an_option_error_speaks_of_the_argument_and_the_cli_of_its_flag():
    from choreo.cli import flag_of
    from choreo.errors import OptionError

    error = OptionError("loop", "9 is too many: {option} at most 3")
    assert (str(error), error.problem) == (
        "loop 9 is too many: loop at most 3",
        "9 is too many: loop at most 3",
    )
    assert error.worded(flag_of) == "--loop 9 is too many: --loop at most 3"
    other = OptionError(
        "loop", "9: {option} fewer, or {allow_past_song}", mentions=("allow_past_song",)
    )
    assert (str(other), other.worded(flag_of)) == (
        "loop 9: loop fewer, or allow_past_song",
        "--loop 9: --loop fewer, or --allow-past-song",
    )


def test_notes_and_warnings_name_arguments_the_same_way_errors_do():
    """A note naming an argument is Worded: a str in the library's words, in flags for the CLI;
    joined into a longer text (a file's problems, a line of the report) it stays so."""
    from choreo.cli import flag_of, in_flags, report_in_flags
    from choreo.errors import ChoreoError, SourceError, Worded, joined

    note = Worded("the beat may be twice that (try {level} double)", ("level",))
    assert note == "the beat may be twice that (try level double)"
    assert in_flags(note) == "the beat may be twice that (try --level double)"
    assert in_flags("no arguments named") == "no arguments named"
    line = joined(": ", ("song.yaml:2:1", note))
    assert (line, in_flags(line)) == (
        "song.yaml:2:1: the beat may be twice that (try level double)",
        "song.yaml:2:1: the beat may be twice that (try --level double)",
    )
    error = SourceError([line, "song.yaml:3:1: plain"])
    assert str(error).splitlines() == [line, "song.yaml:3:1: plain"]
    assert error.worded(flag_of).splitlines() == [in_flags(line), "song.yaml:3:1: plain"]
    assert report_in_flags({"warnings": [note], "n": 1}) == {"warnings": [in_flags(note)], "n": 1}
    named = ChoreoError.naming("overwrite", "out.mp4 exists: pass {option} to replace it")
    assert (str(named), named.worded(flag_of), named.option) == (
        "out.mp4 exists: pass overwrite to replace it",
        "out.mp4 exists: pass --overwrite to replace it",
        "overwrite",
    )
