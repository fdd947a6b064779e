"""The ``bus`` fixture of the emulator's tests: one factory LX-16A (ID 1) on a virtual clock."""

from __future__ import annotations

import pytest
from emulator_helpers import Bus


@pytest.fixture
def bus() -> Bus:
    return Bus()
