"""The bad robot files of tests/data/bad_robots and what loading one reports."""

from __future__ import annotations

from pathlib import Path

import pytest
from paths import DATA

from choreo.errors import SourceError
from choreo.robot.robot_file import load_robot

BAD = DATA / "bad_robots"


def problems_of(path: Path) -> list[str]:
    with pytest.raises(SourceError) as caught:
        load_robot(path)
    return caught.value.problems


def only_problem(case: str) -> tuple[Path, str]:
    path = BAD / case / "robot.yaml"
    [message] = problems_of(path)
    return path, message
