"""The package as users get it: its version, its type hints, and a start-up that stays light."""

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import choreo

ROOT = Path(__file__).resolve().parents[1]


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
    assert result.stdout == "['choreo.cli.arguments', 'choreo.cli.bus_commands'] []\n", (
        result.stderr
    )


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


def test_the_heavy_check_sees_mujoco_when_a_robot_is_loaded():
    """The probe above would notice: loading a robot checks its MuJoCo model."""
    probe = "import sys; from choreo.robot.robot_file import load_robot; load_robot('arm6'); "
    probe += "print('mujoco' in sys.modules)"
    result = subprocess.run(
        [sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.stdout == "True\n", result.stderr


def test_the_public_api_resolves_and_import_choreo_stays_light():
    probe = (
        "import sys, choreo; light = sorted(m for m in ('numpy', 'yaml', 'serial', 'ruckig') "
        "if m in sys.modules); missing = [n for n in choreo.__all__ if not hasattr(choreo, n)]; "
        "print(light, missing, choreo.compile_motion.__module__, choreo.load_robot.__module__)"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.stdout == "[] [] choreo.plan.pipeline choreo.robot.robot_file\n", result.stderr


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


# Modules whose tests live in a test file not named after them: the one place that says where.
# Every other module under choreo/ has its own tests/test_<module>.py.
TESTED_IN = {
    "music/bars.py": ("music/test_bars.py",),
    "music/features.py": ("music/test_bars.py", "test_beats.py"),
    "music/neural.py": ("music/test_neural.py",),
    "bus/transports/jetson.py": ("test_direction.py",),
    "bus/settings.py": ("test_robot.py", "test_play_cli.py"),
    "preview/props.py": ("test_preview_props.py",),
    "preview/reach.py": ("test_preview_reach.py",),
    "preview/stance.py": ("test_preview_judging.py",),
    "preview/walk.py": ("test_preview_gaits.py",),
    "cli/show_commands.py": ("test_show_cli.py",),
    "cli/studio_commands.py": ("test_studio.py", "test_studio_browser.py"),
    "music/report.py": ("test_beats.py", "test_music.py"),
    "show/clock_offset.py": ("test_show.py", "test_show_cli.py"),
    "show/conductor.py": ("test_show.py", "test_show_cli.py"),
    "show/messages.py": ("test_show.py", "test_show_cli.py"),
    "show/network.py": ("test_show.py", "test_show_cli.py"),
    "show/performer.py": ("test_show.py", "test_show_cli.py"),
    "show/showfile.py": ("test_show.py", "test_show_cli.py"),
    "show/staging.py": ("test_show.py", "test_show_cli.py"),
    "studio/address.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/live.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/page.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/posing.py": ("test_studio.py",),
    "studio/scene.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/server.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/session.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/song.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/watch.py": ("test_studio.py", "test_studio_browser.py"),
    "studio/yaml_edit.py": ("test_studio.py", "test_studio_browser.py"),
    "bus/transports/lobot.py": ("test_transport_codecs.py", "test_boards.py"),
    "bus/transports/rrc.py": ("test_transport_codecs.py", "test_boards.py"),
    "bus/transports/raw.py": ("test_direction.py", "test_servo_bus.py"),
    "cli/bus_commands.py": ("test_bus_cli.py",),
    "cli/emulate_commands.py": ("test_pty.py", "test_boards_cli.py"),
    "cli/interop_commands.py": ("test_d6a.py", "test_mirror.py"),
    "cli/motion_commands.py": ("test_validate.py",),
    "cli/music_commands.py": ("test_beats.py",),
    "cli/plan_commands.py": ("test_plan_cli.py", "test_plot.py"),
    "cli/play_commands.py": ("test_play_cli.py",),
    "cli/ports_commands.py": ("test_ports.py",),
    "cli/preview_commands.py": ("test_preview.py", "test_render.py"),
    "cli/record_commands.py": ("test_recorder.py",),
    "cli/robot_commands.py": ("test_robot_cli.py",),
    "cli/servo_commands.py": ("test_servo_config.py",),
    "emulator/backend.py": ("test_sim_url.py",),
    "emulator/protocol_sim.py": ("test_sim_url.py",),
    "emulator/bus_emulator.py": ("test_emulator.py",),
    "emulator/emulated_servo.py": ("test_emulator.py",),
    "emulator/direction_gate.py": ("test_direction.py",),
    "errors.py": ("test_package.py", "test_cli.py"),
    "motion/motion_file.py": ("test_motion.py",),
    "motion/music_block.py": ("test_music.py",),
    "motion/scene.py": ("test_preview_start.py",),
    "music/beat_plot.py": ("test_beats.py",),
    "music/decode.py": ("test_beats.py",),
    "plan/report.py": ("test_plan_report.py",),
    "play/report.py": ("test_play_report.py",),
    "preview/actuator.py": ("test_preview.py",),
    "preview/checks.py": ("test_preview.py", "test_preview_start.py"),
    "preview/model.py": ("test_preview.py",),
    "preview/report.py": ("test_preview.py",),
    "preview/sim.py": ("test_preview.py",),
    "preview/pipeline.py": ("test_preview.py", "test_preview_start.py"),
    "preview/simulated.py": ("test_preview_gaits.py", "test_preview_props.py"),
    "preview/start.py": ("test_preview_start.py",),
    "preview/travel.py": ("test_spatial_preview.py",),
    "preview/gl.py": ("test_render.py",),
    "preview/viewer.py": ("test_preview.py",),
    "robot/joint_source.py": ("test_robot.py", "test_model_check.py"),
    "robot/robot_file.py": ("test_robot.py",),
    "robot/types.py": ("test_robot.py",),
}


def test_every_module_has_a_test_file():
    """The README's promise: a test file per module (tests/test_<module>.py, or TESTED_IN)."""
    package = Path(choreo.__file__).parent
    tests = Path(__file__).parent
    modules = sorted(
        p.relative_to(package).as_posix()
        for p in package.rglob("*.py")
        if p.name not in ("__init__.py", "__main__.py")
    )
    untested = [
        m
        for m in modules
        if not (tests / f"test_{Path(m).stem}.py").is_file()
        and not all((tests / f).is_file() for f in TESTED_IN.get(m, ("",)))
    ]
    assert untested == []
    assert set(TESTED_IN) <= set(modules)  # no entry for a module that is gone


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
