"""Names that become one chunk of a Zenoh key: a performer's, a realm's.

ASCII only, and no ``/``, ``*``, ``$`` or ``?``: each of those would change what the key matches.
"""

from __future__ import annotations

import re

from choreo.errors import OptionError

NAME = re.compile(r"[A-Za-z0-9_-]+", re.ASCII)
NAME_RULE = "ASCII letters, digits, - and _"


def is_name(text: str) -> bool:
    return NAME.fullmatch(text) is not None


def check_name(option: str, text: str) -> str:
    """``text``, or an OptionError naming ``option`` that says what a name may hold."""
    if not is_name(text):
        raise OptionError(option, f"{text!r} is not a name: use only {NAME_RULE}")
    return text


def name_from(text: str) -> str:
    """A name made from ``text`` (a host name): every other character becomes ``-``."""
    return re.sub(r"[^A-Za-z0-9_-]", "-", text, flags=re.ASCII) or "performer"
