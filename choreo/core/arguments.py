"""Checking what a program passes to choreo: each argument's type and range, refused with one
:class:`~choreo.errors.OptionError` that names the argument, shows what was given and says what
would be valid. Nothing is clamped, and no bare ``ValueError``, ``TypeError`` or
``OverflowError`` reaches the caller from a bad argument.

A :class:`Range` is the one statement of which numbers an argument accepts: the library checks
its arguments against it, and the command line (``choreo.cli.arguments``) parses its flags
against the same one, so both accept the same values and say so in the same words.
"""

from __future__ import annotations

import enum
import math
import numbers
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeGuard, TypeVar

from choreo.errors import OptionError

E = TypeVar("E", bound=enum.Enum)
T = TypeVar("T")


@dataclass(frozen=True)
class Range:
    """The finite numbers an argument accepts: above ``above`` or at least ``at_least`` (one of
    them, or neither), at most ``at_most``; only whole numbers with ``whole``. ``unit`` is said
    after the bounds (``"°"``, ``" ms"``)."""

    above: float | None = None
    at_least: float | None = None
    at_most: float | None = None
    whole: bool = False
    unit: str = ""

    def __post_init__(self) -> None:
        if self.above is not None and self.at_least is not None:
            raise ValueError("a range has one lower bound: above or at_least")

    def number(self, value: object) -> float | None:
        """``value`` as a float (an int, where ``whole``) if it is in the range, else ``None``.
        ``True`` and ``False`` are not numbers here, nor is ``2.0`` a whole number."""
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return None
        number: float
        if self.whole:
            if not isinstance(value, numbers.Integral):
                return None
            number = int(value)  # finite however large
        else:
            try:
                number = float(value)
            except OverflowError:  # an int beyond any float
                return None
            if not math.isfinite(number):
                return None
        inside = (
            (self.above is None or number > self.above)
            and (self.at_least is None or number >= self.at_least)
            and (self.at_most is None or number <= self.at_most)
        )
        return number if inside else None

    def __contains__(self, value: object) -> bool:
        return self.number(value) is not None

    def __str__(self) -> str:
        """In words: ``a number > 0 and <= 5°``."""
        bounds = [
            f"{sign} {bound:g}"
            for sign, bound in ((">", self.above), (">=", self.at_least), ("<=", self.at_most))
            if bound is not None
        ]
        kind = "a whole number" if self.whole else "a number"
        return " and ".join([f"{kind} {bounds[0]}" if bounds else kind, *bounds[1:]]) + (
            self.unit if bounds else ""
        )

    def scaled(self, factor: float, unit: str) -> Range:
        """The same range in another unit: ``TIMEOUT_S.scaled(1000, " ms")``."""

        def times(bound: float | None) -> float | None:
            return None if bound is None else bound * factor

        return Range(times(self.above), times(self.at_least), times(self.at_most), False, unit)


NUMBER = Range()
POSITIVE = Range(above=0)
NON_NEGATIVE = Range(at_least=0)
COUNT = Range(at_least=1, whole=True)  # how many times, how many in a row: 1 and up


def shown(value: object) -> str:
    """A given value as a message shows it: its repr, cut short, with its type where the repr
    does not say it (a dict, a path, an object)."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    if isinstance(value, (str, int, float, type(None))):
        return text
    return f"{type(value).__name__} {text}"


def check_number(option: str, value: object, valid: Range = NUMBER) -> float:
    """``value`` as a float (an int, where ``valid.whole``) if it is in ``valid``."""
    number = valid.number(value)
    if number is None:
        raise OptionError(option, f"must be {valid}, got {shown(value)}")
    return number


def check_optional_number(option: str, value: object, valid: Range = NUMBER) -> float | None:
    """As :func:`check_number`, with ``None`` (the default: not given) accepted."""
    if value is None:
        return None
    try:
        return check_number(option, value, valid)
    except OptionError:
        raise OptionError(option, f"must be {valid}, or None, got {shown(value)}") from None


def check_flag(option: str, value: object) -> bool:
    """``value`` if it is ``True`` or ``False`` (a string such as ``"no"`` would count as true)."""
    if isinstance(value, bool):
        return value
    raise OptionError(option, f"must be True or False, got {shown(value)}")


def check_member(option: str, value: object, kind: type[E]) -> E:
    """A member of the enum ``kind``: given as one, or by its value (``"pose"``)."""
    if isinstance(value, kind):
        return value
    for member in kind:
        if isinstance(value, str) and value == member.value:
            return member
    names = ", ".join(repr(m.value) for m in kind)
    article = "an" if kind.__name__[0] in "AEIOU" else "a"
    raise OptionError(
        option,
        f"must be {article} {kind.__name__} or one of its values {names}, got {shown(value)}",
    )


def check_choice(option: str, value: object, choices: Sequence[str]) -> str:
    """``value`` if it is one of the strings ``choices``."""
    if isinstance(value, str) and value in choices:
        return value
    raise OptionError(option, f"must be one of {', '.join(map(repr, choices))}, got {shown(value)}")


def check_type(option: str, value: object, kind: type[T], what: str) -> T:
    """``value`` if it is a ``kind``; ``what`` says what to pass instead (``"a PlayOptions,
    e.g. PlayOptions(speed=2)"``)."""
    if isinstance(value, kind):
        return value
    raise OptionError(option, f"must be {what}, got {shown(value)}")


def check_callable(option: str, value: object, optional: bool = False) -> None:
    """Refuse a ``value`` that cannot be called (or is ``None``, unless ``optional``)."""
    if not (callable(value) or (optional and value is None)):
        raise OptionError(
            option, f"must be a function{' or None' if optional else ''}, got {shown(value)}"
        )


def check_text(option: str, value: object, optional: bool = False) -> str | None:
    """``value`` if it is a string (or ``None``, with ``optional``)."""
    if isinstance(value, str) or (optional and value is None):
        return value
    raise OptionError(
        option, f"must be a string{' or None' if optional else ''}, got {shown(value)}"
    )


def is_path(value: object) -> TypeGuard[str | os.PathLike[str]]:
    """Whether ``value`` names a file: a non-empty string or a path-like object."""
    return (isinstance(value, str) and value != "") or isinstance(value, os.PathLike)


def check_path(option: str, value: object, what: str = "a path") -> Path:
    """``value`` as a :class:`Path` if it is a non-empty string or a path-like object."""
    if is_path(value):
        return Path(value)
    raise OptionError(option, f"must be {what} (a str or os.PathLike), got {shown(value)}")
