"""Every Python code block in README.md and docs/*.md runs as written, and so does every command
the README shows in a shell block (those that need a real serial port excepted)."""

from __future__ import annotations

import dataclasses
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from paths import REPO
from virtual_choreo import in_virtual_time

from choreo.cli import main

ROOT = REPO
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
def test_python_block_runs(code, monkeypatch):
    """In this process, as a script of its own (``__main__``, from the repository's folder): it
    pays no interpreter start and no imports (librosa's: 8 s of CPU in a process of its own).
    One that renders would need a process of its own, as previews have (see ``run``)."""
    assert "render_preview" not in code, "run a block that renders in a process of its own"
    monkeypatch.chdir(ROOT)
    exec(compile(code, "<the block>", "exec"), {"__name__": "__main__"})


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    """A folder holding the repo's motions and models, so files a command writes land there."""
    for folder in ("motions", "models", "shows"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    return tmp_path


@pytest.fixture
def run(workdir, monkeypatch, capsys, request):
    """``run(COMMAND, error=None)``: ``choreo ARGS`` as the README writes it, in ``workdir``, every
    emulator in virtual time (virtual_choreo.py); it succeeds, or fails with exactly ``error``.
    In this process, which pays the imports (and librosa's warm-up) once for all of them, and
    no interpreter start for each (a preview's renders here too: test_gl.py's tests choose the
    back-end whether or not this process has rendered)."""
    monkeypatch.chdir(workdir)
    in_virtual_time(monkeypatch.setattr)

    def run_command(command: str, error: str | None = None) -> None:
        args = shlex.split(command)[1:]
        if args[0] == "beats":
            request.getfixturevalue("warm_librosa")  # once per session, not in this test
        capsys.readouterr()
        try:
            code = main(args)
        except SystemExit as exited:  # argparse's refusal
            code = exited.code
        stderr = capsys.readouterr().err
        if error is None:
            assert code == 0, stderr
        else:
            assert code == 1, stderr
            assert stderr.strip() == error

    return run_command


@pytest.mark.parametrize(
    "command",
    [
        c
        for c in readme_commands()
        if c.block not in SERVED_BLOCKS and not HARDWARE_PORT.search(c.text)
    ],
    ids=lambda c: c.text,
)
def test_readme_command_runs(command, run):
    run(command.text, command.error)


@pytest.mark.parametrize("block", sorted(SERVED_BLOCKS))
def test_readme_block_with_a_server_runs(block, workdir, run):
    """A block that starts a server with ``&`` (``choreo emulate --pty PATH``, ``choreo perform``,
    ``choreo studio``): it is started, the block's other commands run against it, then it is
    stopped as Ctrl-C would."""
    # the README's /tmp links moved into this test's folder: two runs on one machine (CI jobs,
    # several checkouts) must not share one pty link
    commands = [
        dataclasses.replace(c, text=c.text.replace("/tmp/", f"{workdir}/"))
        for c in readme_commands()
        if c.block == block
    ]
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
                ready = server.stdout.readline()  # the server says it is up
                up = ("emulating", "waiting for a show", "choreo studio:")
                assert any(word in ready for word in up), server.stderr
            elif not HARDWARE_PORT.search(command.text):
                run(command.text, command.error)
    finally:
        for server in servers:
            server.send_signal(signal.SIGINT)
        for server in servers:
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()  # leave no server behind, holding its port, and fail
                raise


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
def test_commands_the_readme_describes_run(command, run):
    """The README's table and text name these with placeholders; concrete cases, on the emulator
    where a port is needed (a serial port at /dev/... is what the emulator's URL stands for)."""
    run(command)


def test_a_vendor_action_group_imports_and_validates_as_the_readme_says(workdir, run):
    """`choreo import d6a FILE.d6a --robot R -o motion.yaml`, then `choreo validate --stretch`,
    on an action group written by `choreo export d6a`."""
    run("choreo export d6a motions/arm6/wave.yaml -o wave.d6a")
    run("choreo import d6a wave.d6a --robot arm6 -o motion.yaml")
    run("choreo validate --stretch motion.yaml")
    assert "robot: arm6" in (workdir / "motion.yaml").read_text()


def test_the_quickstart_is_two_commands():
    """One line installs and plays and previews, one installs and runs the tests."""
    quickstart = (ROOT / "README.md").read_text().split("## Quickstart\n", 1)[1]
    quickstart = quickstart.split("\n## ", 1)[0]
    [block] = re.findall(r"^```sh\n(.*?)^```$", quickstart, re.MULTILINE | re.DOTALL)
    lines = block.strip().splitlines()
    assert [line.split()[:2] for line in lines] == [["pip", "install"], ["pip", "install"]]


def test_every_yaml_file_the_readme_shows_validates(workdir, run):
    """The motion example (beside the block it includes) and the show file, as written."""
    blocks = code_blocks(ROOT / "README.md", "yaml")
    assert len(blocks) == 2
    folder = workdir / "mine"
    folder.mkdir()
    shutil.copy(ROOT / "motions" / "arm6" / "wave_block.yaml", folder)
    for index, (_, text) in enumerate(blocks):
        path = folder / f"block{index}.yaml"
        path.write_text(text)
        run(f"choreo validate --no-physics {path}")
