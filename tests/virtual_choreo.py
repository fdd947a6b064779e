"""``python -m choreo`` with every emulator in virtual time: the built-in one (a command without
``--port``) and ``sim://`` URLs that don't choose a clock. tests/test_docs.py runs the README's
commands as written this way, so that playing a 20 s dance on the emulator takes the time to
plan it, not 20 s (the docs' subject is that the commands work, not their timing).

Run: python tests/virtual_choreo.py ARGS (as ``choreo ARGS``)
"""

from __future__ import annotations

import sys
from collections.abc import Callable

from emulated import built_in_emulator_in_virtual_time

from choreo.cli import main
from choreo.emulator import backend
from choreo.play import robot_bus

connect_sim_url = backend.connect


def connect_in_virtual_time(url: str, *args, **kwargs):
    if "clock=" not in url:
        url += ("&" if "?" in url else "?") + "clock=virtual"
    return connect_sim_url(url, *args, **kwargs)


def in_virtual_time(set_attribute: Callable[[object, str, object], None]) -> None:
    """Every emulator a command makes runs in virtual time: ``set_attribute`` is ``setattr`` in
    a process of its own, ``monkeypatch.setattr`` in a test."""
    set_attribute(robot_bus, "built_in_emulator", built_in_emulator_in_virtual_time)
    set_attribute(backend, "connect", connect_in_virtual_time)


if __name__ == "__main__":
    in_virtual_time(setattr)
    sys.exit(main())
