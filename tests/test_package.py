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
    "bus/transports/jetson.py": ("test_direction.py",),
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
