"""The ``bus_and_emulator`` fixture of the bus's tests: a ServoBus on its own emulator, once for
each way echo can be set up."""

from __future__ import annotations

import pytest
from servo_bus_helpers import ECHO_SETUPS, make_bus


@pytest.fixture(params=ECHO_SETUPS, ids=lambda p: f"echo={int(p[0])}-{p[1].value}")
def bus_and_emulator(request):
    echo, mode = request.param
    return make_bus(echo=echo, mode=mode)
