"""``choreo scan``, ``choreo servo``, ``choreo emulate``."""

from __future__ import annotations


def register(subparsers) -> None:
    pass
