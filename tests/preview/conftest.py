"""Fixtures the preview's test files share: the small arm of tests/data and the hexapod."""

from __future__ import annotations

import pytest
from paths import DATA, REPO

from choreo.robot.robot_file import load_robot


@pytest.fixture(scope="module")
def arm3():
    return load_robot(DATA / "preview" / "models" / "arm3" / "robot.yaml")


@pytest.fixture(scope="module")
def hexapod():
    return load_robot(REPO / "models" / "hexapod18" / "robot.yaml")
