"""The architecture's import contracts (pyproject.toml, [tool.importlinter]): imports run one way
between the subpackages, and ruckig, mujoco and pyserial stay in the modules at their edges."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINT = (
    "import sys; from importlinter.cli import lint_imports; "
    "sys.exit(lint_imports(config_filename='pyproject.toml', no_cache=True, no_logo=True))"
)


def lint_imports(root: Path) -> subprocess.CompletedProcess:
    """lint-imports on the choreo package under ``root`` with the project's contracts."""
    return subprocess.run(
        [sys.executable, "-c", LINT],
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(root)},
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_every_contract_is_kept():
    result = lint_imports(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "3 kept, 0 broken" in result.stdout


def test_an_import_running_back_up_is_caught(tmp_path):
    """The contracts would notice: the emulator importing the player breaks them."""
    shutil.copytree(ROOT / "choreo", tmp_path / "choreo", ignore=shutil.ignore_patterns("*.pyc"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    trace = tmp_path / "choreo" / "emulator" / "trace.py"
    trace.write_text(trace.read_text() + "\nfrom choreo.play.player import Player  # noqa\n")
    result = lint_imports(tmp_path)
    assert result.returncode == 1
    assert "choreo.emulator.trace -> choreo.play.player" in result.stdout
