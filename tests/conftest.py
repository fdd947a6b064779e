"""Fixtures shared by several test files."""

from __future__ import annotations

import pytest
from emulated import home_specs, served_on_a_pty

from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator
from choreo.robot.robot_file import load_robot


@pytest.fixture
def arm_on_a_pty(tmp_path):
    """arm6's servos at home, on a pty served in real time: (emulator, link path)."""
    emulator = BusEmulator(home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyARM") as link:
        yield emulator, link
