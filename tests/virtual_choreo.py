"""The command line with every emulator in virtual time: the built-in one (a command without
``--port``) and ``sim://`` URLs that don't choose a clock. tests/test_docs.py runs the README's
commands as written this way (in its own process), so that playing a 20 s dance on the emulator
takes the time to plan it, not 20 s (the docs' subject is that the commands work, not their
timing).
"""

from __future__ import annotations

from collections.abc import Callable

from emulated import built_in_emulator_in_virtual_time

from choreo.emulator import backend
from choreo.play import robot_bus

connect_sim_url = backend.connect


def connect_in_virtual_time(url: str, *args, **kwargs):
    if "clock=" not in url:
        url += ("&" if "?" in url else "?") + "clock=virtual"
    return connect_sim_url(url, *args, **kwargs)


def in_virtual_time(set_attribute: Callable[[object, str, object], None]) -> None:
    """Every emulator a command makes runs in virtual time (``set_attribute``: a test's
    ``monkeypatch.setattr``)."""
    set_attribute(robot_bus, "built_in_emulator", built_in_emulator_in_virtual_time)
    set_attribute(backend, "connect", connect_in_virtual_time)
