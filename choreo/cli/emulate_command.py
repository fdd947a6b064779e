"""``choreo emulate``: the servo emulator on a pseudo-terminal."""

from __future__ import annotations


def register(subparsers) -> None:
    pass
