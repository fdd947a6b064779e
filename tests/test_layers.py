"""The architecture's import contracts (pyproject.toml, [tool.importlinter]): imports run one way
between the subpackages, and ruckig, mujoco and pyserial stay in the modules at their edges."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import REPO

ROOT = REPO
# lint-imports with the project's contracts on the choreo package under each root given, in one
# process (its start and importlinter's import cost 0.4 s of CPU): each root's package is found
# afresh, and what lint-imports said is printed as one JSON line [root, exit code, output]
LINT_EACH = """
import contextlib, importlib, io, json, os, sys
from importlinter.cli import lint_imports
for root in sys.argv[1:]:
    for name in [m for m in sys.modules if m == "choreo" or m.startswith("choreo.")]:
        del sys.modules[name]
    sys.path.insert(0, root)
    importlib.invalidate_caches()
    os.chdir(root)
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        code = lint_imports(config_filename="pyproject.toml", no_cache=True, no_logo=True)
    sys.path.remove(root)
    print(json.dumps([root, code, said.getvalue()]))
"""

WRONG_IMPORTS = [  # an import running back up; a heavy library outside the modules allowed it
    ("emulator/trace.py", "from choreo.play.player import Player", "choreo.play.player"),
    ("music/report.py", "import mujoco", "mujoco"),
    ("plan/ticks.py", "import ruckig", "ruckig"),
    ("show/network.py", "import serial", "serial"),
]


@pytest.fixture(scope="module")
def linted(tmp_path_factory) -> dict[str | None, tuple[int, str]]:
    """lint-imports' exit code and output for the repository (None) and for a copy of it with
    each of WRONG_IMPORTS added (by its module), linted in that order: the repository first, so
    a result carried over from one root to the next could only make a wrong import look kept."""
    roots: dict[str | None, Path] = {None: ROOT}
    for module, line, _ in WRONG_IMPORTS:
        root = roots[module] = tmp_path_factory.mktemp(Path(module).stem)
        shutil.copytree(ROOT / "choreo", root / "choreo", ignore=shutil.ignore_patterns("*.pyc"))
        shutil.copy(ROOT / "pyproject.toml", root)
        path = root / "choreo" / module
        path.write_text(path.read_text() + f"\n{line}  # noqa\n")
    result = subprocess.run(
        [sys.executable, "-c", LINT_EACH, *map(str, roots.values())],
        env={**os.environ, "PYTHONPATH": ""},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    said = [json.loads(line) for line in result.stdout.splitlines()]
    assert [root for root, _, _ in said] == list(map(str, roots.values())), result.stdout
    return {module: (code, output) for module, (_, code, output) in zip(roots, said)}


def test_every_contract_is_kept(linted):
    code, output = linted[None]
    assert code == 0, output
    assert "4 kept, 0 broken" in output


@pytest.mark.parametrize(("module", "line", "caught"), WRONG_IMPORTS)
def test_an_import_against_the_contracts_is_caught(linted, module, line, caught):
    """The contracts would notice each kind of wrong import."""
    code, output = linted[module]
    assert code == 1
    importer = "choreo." + module.removesuffix(".py").replace("/", ".")
    assert f"{importer} -> {caught}" in output
