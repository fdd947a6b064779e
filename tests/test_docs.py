"""Every Python code block in README.md and docs/*.md runs as written, and so does every command
the README shows in a shell block (those that need a real serial port excepted)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
HARDWARE_PORT = re.compile(r"--port\s+(/dev/|COM)")


def code_blocks(path: Path, language: str) -> list[tuple[int, str]]:
    """(line, code) of each fenced block in ``language``."""
    text = path.read_text()
    return [
        (text.count("\n", 0, match.start()) + 2, match.group(1))
        for match in re.finditer(rf"^```{language}\n(.*?)^```$", text, re.MULTILINE | re.DOTALL)
    ]


PYTHON_BLOCKS = [
    pytest.param(code, id=f"{path.name}:{line}")
    for path in DOCS
    for line, code in code_blocks(path, "python")
]
README_COMMANDS = [
    command.strip()
    for _, block in code_blocks(ROOT / "README.md", "sh")
    for line in block.splitlines()
    for command in line.split("#")[0].split("&&")
    if command.strip().startswith("choreo ")
]


def env_importing_this_checkout() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def test_the_docs_have_python_blocks_and_commands():
    assert len(PYTHON_BLOCKS) >= 3
    assert any(HARDWARE_PORT.search(c) for c in README_COMMANDS)
    assert sum(not HARDWARE_PORT.search(c) for c in README_COMMANDS) >= 3


@pytest.mark.parametrize("code", PYTHON_BLOCKS)
def test_python_block_runs(code):
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        env=env_importing_this_checkout(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    """A folder holding the repo's motions and models, so files a command writes land there."""
    for folder in ("motions", "models"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    return tmp_path


def run_command(command: str, folder: Path) -> None:
    """``choreo ARGS`` as ``python -m choreo ARGS`` with this checkout, in ``folder``."""
    argv = [sys.executable, "-m", "choreo", *shlex.split(command)[1:]]
    result = subprocess.run(
        argv,
        cwd=folder,
        env=env_importing_this_checkout(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize(
    "command", [c for c in README_COMMANDS if not HARDWARE_PORT.search(c)], ids=str
)
def test_readme_command_runs(command, workdir):
    run_command(command, workdir)


@pytest.mark.parametrize(
    "command",
    [
        "choreo scan --port sim://?ids=1-18 --ids 1-18",
        "choreo plan motions/arm6/wave.yaml --plot plan.png",
        "choreo validate --stretch motions/tonypi/bow.yaml",
        "choreo play motions/hexapod18/stand_up.yaml --dry-run",
        "choreo mirror motions/arm6/wave.yaml -o mirrored.yaml",
    ],
)
def test_commands_the_readme_describes_run(command, workdir):
    """The README's table and text name these with placeholders; concrete cases, on the emulator
    where a port is needed (a serial port at /dev/... is what the emulator's URL stands for)."""
    run_command(command, workdir)


def test_a_vendor_action_group_imports_and_validates_as_the_readme_says(workdir):
    """`choreo import d6a FILE.d6a --robot R -o motion.yaml`, then `choreo validate --stretch`,
    on an action group written by `choreo export d6a`."""
    run_command("choreo export d6a motions/arm6/wave.yaml -o wave.d6a", workdir)
    run_command("choreo import d6a wave.d6a --robot arm6 -o motion.yaml", workdir)
    run_command("choreo validate --stretch motion.yaml", workdir)
    assert "robot: arm6" in (workdir / "motion.yaml").read_text()
