"""The architecture's import contracts (pyproject.toml, [tool.importlinter]): imports run one way
between the subpackages, and ruckig, mujoco and pyserial stay in the modules at their edges."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import REPO

ROOT = REPO
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
    assert "4 kept, 0 broken" in result.stdout


@pytest.mark.parametrize(
    ("module", "line", "caught"),
    [  # an import running back up; a heavy library outside the modules allowed to import it
        ("emulator/trace.py", "from choreo.play.player import Player", "choreo.play.player"),
        ("music/report.py", "import mujoco", "mujoco"),
        ("plan/ticks.py", "import ruckig", "ruckig"),
        ("show/network.py", "import serial", "serial"),
    ],
)
def test_an_import_against_the_contracts_is_caught(tmp_path, module, line, caught):
    """The contracts would notice each kind of wrong import."""
    shutil.copytree(ROOT / "choreo", tmp_path / "choreo", ignore=shutil.ignore_patterns("*.pyc"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    path = tmp_path / "choreo" / module
    path.write_text(path.read_text() + f"\n{line}  # noqa\n")
    result = lint_imports(tmp_path)
    assert result.returncode == 1
    importer = "choreo." + module.removesuffix(".py").replace("/", ".")
    assert f"{importer} -> {caught}" in result.stdout
