"""Every Python code block in README.md and docs/*.md runs as written, and so does every command
the README shows in a shell block (those that need a real serial port excepted)."""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
from dataclasses import dataclass
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


@dataclass(frozen=True)
class Command:
    """A `choreo ...` line of a README shell block: ``background`` when it ends with ``&`` (a
    server the block's next lines use); ``error`` when the README shows it failing, as the
    ``# choreo: error: ...`` line right after it."""

    text: str
    block: int
    background: bool = False
    error: str | None = None


def readme_commands() -> list[Command]:
    commands: list[Command] = []
    for block_index, (_, block) in enumerate(code_blocks(ROOT / "README.md", "sh")):
        lines = block.splitlines()
        for i, line in enumerate(lines):
            error = _error_shown_after(lines[i + 1 :])
            for part in line.split("#")[0].split("&&"):
                text = part.strip()
                if text.startswith("choreo "):
                    background = text.endswith("&")
                    text = text.rstrip("&").strip()
                    commands.append(Command(text, block_index, background, error))
    return commands


def _error_shown_after(lines: list[str]) -> str | None:
    """The ``# choreo: error: ...`` comment opening ``lines``, joined over its ``# `` lines."""
    if not lines or not lines[0].strip().startswith("# choreo: error:"):
        return None
    shown = [lines[0].strip()[2:]]
    for line in lines[1:]:
        if not line.startswith("# ") or line.startswith("# choreo"):
            break
        shown.append(line[2:].strip())
    return " ".join(shown)


README_COMMANDS = [c.text for c in readme_commands()]
SERVED_BLOCKS = {c.block for c in readme_commands() if c.background}


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


# `python -m choreo`, but a command without --port plays on the built-in emulator in virtual time
VIRTUAL_CHOREO = [sys.executable, str(ROOT / "tests" / "virtual_choreo.py")]


def run_command(command: str, folder: Path, error: str | None = None) -> None:
    """``choreo ARGS`` as ``python -m choreo ARGS`` with this checkout, in ``folder`` (the
    built-in emulator on a virtual clock); it succeeds, or fails with exactly ``error`` when that
    is given."""
    argv = [*VIRTUAL_CHOREO, *shlex.split(command)[1:]]
    result = subprocess.run(
        argv,
        cwd=folder,
        env=env_importing_this_checkout(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    if error is None:
        assert result.returncode == 0, result.stderr
    else:
        assert result.returncode == 1, result.stderr
        assert result.stderr.strip() == error


@pytest.mark.parametrize(
    "command",
    [
        c
        for c in readme_commands()
        if c.block not in SERVED_BLOCKS and not HARDWARE_PORT.search(c.text)
    ],
    ids=lambda c: c.text,
)
def test_readme_command_runs(command, workdir):
    run_command(command.text, workdir, command.error)


@pytest.mark.parametrize("block", sorted(SERVED_BLOCKS))
def test_readme_block_with_a_server_runs(block, workdir):
    """A block that starts a server with ``&`` (``choreo emulate --pty PATH``): it is started,
    the block's other commands run against it, then it is stopped as Ctrl-C would."""
    commands = [c for c in readme_commands() if c.block == block]
    servers = []
    try:
        for command in commands:
            if command.background:
                argv = [sys.executable, "-m", "choreo", *shlex.split(command.text)[1:]]
                server = subprocess.Popen(
                    argv,
                    cwd=workdir,
                    env=env_importing_this_checkout(),
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    text=True,
                )
                servers.append(server)
                assert server.stdout is not None
                assert "emulating" in server.stdout.readline(), server.stderr
            elif not HARDWARE_PORT.search(command.text):
                run_command(command.text, workdir, command.error)
    finally:
        for server in servers:
            server.send_signal(signal.SIGINT)
            server.wait(timeout=30)


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
