"""The package as users get it: its version, its type hints, and a start-up that stays light."""

import subprocess
import sys
import tomllib
from pathlib import Path

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
