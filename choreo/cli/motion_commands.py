"""``choreo validate`` (and later plan, preview, play)."""

from __future__ import annotations


def register(subparsers) -> None:
    pass
