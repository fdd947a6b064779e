"""Helpers for tests of ServoBus: a bus on an emulator of its own, on a virtual clock, with echo
set up each way."""

from __future__ import annotations

from choreo.bus.servo_bus import EchoMode, ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection


def make_bus(ids=(1, 2, 3), *, echo=False, mode=EchoMode.AUTO, model="LX-224HV", **kwargs):
    emulator = BusEmulator(ids, model=model, clock=VirtualClock(), echo=echo)
    return ServoBus(connection(emulator, echo=mode), **kwargs), emulator


ECHO_SETUPS = [
    (False, EchoMode.NONE),
    (False, EchoMode.AUTO),
    (True, EchoMode.AUTO),
    (True, EchoMode.DISCARD),
]
