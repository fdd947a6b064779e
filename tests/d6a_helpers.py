"""The vendor's action-group files in tests/data/tonypi, read as rows and imported as a user
would."""

from __future__ import annotations

import shutil
import sqlite3
from contextlib import closing
from pathlib import Path

from paths import REPO

from choreo.cli import main

VENDOR = REPO / "tests" / "data" / "tonypi"


VENDOR_FILES = sorted(VENDOR.glob("*.d6a"))


def sqlite_rows(path: Path) -> list[tuple]:
    with closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as connection:
        return connection.execute('SELECT * FROM ActionGroup ORDER BY "Index"').fetchall()


def edited_copy(source: Path, target: Path, *updates: str) -> Path:
    """A copy of an action group with SQL statements applied."""
    shutil.copy(source, target)
    target.chmod(0o644)
    with closing(sqlite3.connect(target)) as connection:
        for statement in updates:
            connection.execute(statement)
        connection.commit()
    return target


def import_to(tmp_path: Path, source: Path, robot: str = "tonypi", *extra: str) -> Path:
    out = tmp_path / f"{source.stem}.yaml"
    assert main(["import", "d6a", str(source), "--robot", robot, "-o", str(out), *extra]) == 0
    return out
