"""The motion files of tests/data (good and bad) and what loading a bad one reports."""

from __future__ import annotations

from pathlib import Path

import pytest
from paths import DATA

from choreo.errors import SourceError
from choreo.motion.motion_file import load_motion

GOOD = DATA / "motions"


BAD = DATA / "bad_motions"


def problems_of(path: Path) -> list[str]:
    with pytest.raises(SourceError) as caught:
        load_motion(path)
    return caught.value.problems


def only_problem(name: str) -> tuple[Path, str]:
    path = BAD / name
    [message] = problems_of(path)
    return path, message
