"""The ``choreo`` command: the only place that prints or configures logging.

Each command group lives in its own module (``<topic>_commands.py``, with ``register(subparsers)``);
:mod:`choreo.cli.command_line` holds the parser, :func:`main` and the exit codes, and its names
are this package's (``from choreo.cli import main``), loaded on first use.

This module itself stays light: the console script and ``python -m choreo`` import it and call
:func:`program`, which loads the command line only then, where Ctrl-C ends the command as it does
once it runs: ``choreo: interrupted``, exit 130, no traceback (the loading takes a tenth of a
second, several times that on a busy machine).
"""

from __future__ import annotations

import importlib
import sys
from types import ModuleType
from typing import TYPE_CHECKING

# The command line's names other modules use, found by __getattr__ (and "program", "interrupted")
__all__ = [
    "program",
    "interrupted",
    "COMMAND_MODULES",
    "build_parser",
    "flag_of",
    "hint_for",
    "in_flags",
    "main",
    "one_blas_thread",
    "report_in_flags",
    "restore_mujoco_gl",
]


def program() -> int:
    """The ``choreo`` program: its console script, ``python -m choreo``."""
    try:
        command_line = _command_line()
    except KeyboardInterrupt:
        return interrupted()
    return command_line.program()


def interrupted() -> int:
    """Ctrl-C (or a stop signal taken as it) ended the command: one line, exit 130."""
    print("choreo: interrupted", file=sys.stderr)
    return 130


def __getattr__(name: str) -> object:
    """The command line's names (``main``, ``flag_of``...), loaded on first use."""
    try:
        return getattr(_command_line(), name)
    except AttributeError:
        raise AttributeError(f"module 'choreo.cli' has no attribute {name!r}") from None


def _command_line() -> ModuleType:
    # not `from choreo.cli import command_line`: that asks this module's __getattr__ first
    return importlib.import_module("choreo.cli.command_line")


if TYPE_CHECKING:  # what type checkers and editors see: the names __getattr__ finds
    from choreo.cli.command_line import (
        COMMAND_MODULES,
        build_parser,
        flag_of,
        hint_for,
        in_flags,
        main,
        one_blas_thread,
        report_in_flags,
        restore_mujoco_gl,
    )
