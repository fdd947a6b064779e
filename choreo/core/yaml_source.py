"""YAML with line:col marks, typed reading of its values, and the list of problems found in it.

Robot and motion files are read through ``yaml.compose`` (the safe loader's node tree), so every
value keeps where it was written. Readers never stop at the first problem: each check reports
into a shared ``Problems`` list and returns ``None`` for a value it could not accept, and the
caller raises one ``SourceError`` with everything at the end.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import yaml

from choreo.core.file_kind import not_a_file
from choreo.errors import SourceError, joined

Node = yaml.Node


@dataclass(frozen=True)
class SourceLocation:
    """Where a value came from, for messages: ``path:line:col``."""

    path: Path
    line: int  # 1-based
    col: int  # 1-based
    # for a keyframe of an included file: the include entries that brought it in, innermost
    # first (not part of the place itself: equal places compare equal however reached)
    included_at: tuple[SourceLocation, ...] = field(default=(), compare=False)

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.col}"

    @property
    def through(self) -> str:
        """`` (included at b.yaml:4:5, included at a.yaml:7:5)``, or ``""``."""
        if not self.included_at:
            return ""
        return " (" + ", ".join(f"included at {entry}" for entry in self.included_at) + ")"


class Entry(NamedTuple):  # (a tuple: made for every key of a file, and quicker to make)
    """One ``key: value`` of a YAML mapping."""

    key: str
    key_node: Node
    value: Node


class Problems:
    """Messages ``path:line:col: what is wrong and what would be valid``, collected."""

    def __init__(self) -> None:
        self._lines: list[str] = []

    def add(self, where: SourceLocation, message: str) -> None:
        self.extend([joined(": ", (str(where), message))])  # a Worded message stays one

    def extend(self, lines: Iterable[str]) -> None:
        for line in lines:
            if line not in self._lines:  # a bad default is read once per joint: say it once
                self._lines.append(line)

    @property
    def messages(self) -> list[str]:
        """Grouped by file (in the order files were first reported), by line:col within one."""
        files: dict[str, int] = {}

        def place(line: str) -> tuple[int, int, int]:
            match = _PREFIX.match(line)
            path, row, col = match.groups() if match else ("", "0", "0")
            return files.setdefault(path, len(files)), int(row), int(col)

        return sorted(self._lines, key=place)

    def __bool__(self) -> bool:
        return bool(self._lines)


_PREFIX = re.compile(r"^(.+?):(\d+):(\d+): ")


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices``, or ``""`` when none is close."""
    import difflib  # only for a message: not on every load

    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


# A value quoted in a message is cut to this many characters of its first line: a file read by
# mistake (a motion's robot: naming /etc/passwd) is one long text, and a message shows what
# was found, not the whole of it.
QUOTED_CHARS = 60


def _cut(text: str) -> tuple[str, bool]:
    """The start of ``text`` a message shows, and whether that leaves some of it out."""
    first, *more = text.splitlines() or [""]
    return first[:QUOTED_CHARS], bool(more) or len(first) > QUOTED_CHARS


def shortened(text: str) -> str:
    """``text`` cut to its first line and ``QUOTED_CHARS`` characters, "…" where cut."""
    start, cut = _cut(text)
    return start + ("…" if cut else "")


def quoted(value: object) -> str:
    """``repr(value)`` for a message, a text cut as ``shortened`` cuts it, outside the quotes:
    ``'a long line of text that is not what was asked for, and goes'…``."""
    if not isinstance(value, str):
        return shortened(repr(value))
    start, cut = _cut(value)
    return repr(start) + ("…" if cut else "")


def fmt(value: float) -> str:
    """A number for messages: ``90``, ``-12.5``, ``0.333333``; a whole number as written up to
    16 digits, then ``1e+300`` (some are too large for a float)."""
    if isinstance(value, int) and not isinstance(value, bool):
        if abs(value) < 10**16:
            return str(value)
        from decimal import Context, Decimal  # only for a message: not on every load

        return f"{Decimal(value).normalize(Context(prec=6)):g}"
    return f"{value:g}"


FLOAT_TAG = "tag:yaml.org,2002:float"
INT_TAG = "tag:yaml.org,2002:int"
STR_TAG = "tag:yaml.org,2002:str"

# libyaml's parser (same marks, same safety) is several times faster where PyYAML has it.
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


# A 2,000-keyframe motion for 18 servos is well under 1 MiB; reading stops here, so a wrong path
# (/dev/zero, a video) is refused instead of filling the memory.
MAX_FILE_BYTES = 16 * 1024 * 1024


def parse_yaml_file(path: Path) -> Node | None:
    """The node tree of a one-document YAML file (``None`` if empty); ``SourceError`` otherwise."""
    kind = not_a_file(path)
    if kind is not None:
        raise SourceError(f"{path}:1:1: cannot read the file: it is {kind}, not a file")
    try:
        with open(path, "rb") as file:
            data = file.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            raise SourceError(
                f"{path}:1:1: cannot read the file: it is larger than "
                f"{MAX_FILE_BYTES // (1024 * 1024)} MiB, the most a robot or motion file may be"
            )
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) else "it is not UTF-8 text"
        raise SourceError(f"{path}:1:1: cannot read the file: {reason}") from None
    try:
        return _compose(path, text)
    except yaml.YAMLError as error:
        line, col, problem = yaml_problem(error, text)
        raise SourceError(f"{path}:{line}:{col}: not valid YAML: {problem}") from None


# The loader builds the node tree by recursion: 30,000 nested "[" overflow libyaml's C stack (a
# segfault) or Python's. The deepest shipped file nests 6 levels.
MAX_DEPTH = 64


def _compose(path: Path, text: str) -> Node | None:
    """The node tree, in one pass where nothing is nested more than MAX_DEPTH deep and the
    file is valid YAML. Otherwise the events are read first, without recursion, as ever: a
    syntax error or a collection nested too deep is said where it comes first, and the tree is
    built only if there is neither (libyaml's own depth bound is a syntax error to the fast
    pass, so any fault takes the careful path)."""
    with contextlib.suppress(_DeepNode, yaml.YAMLError):
        return yaml.compose(text, Loader=_BoundedLoader)
    _check_depth(path, text)
    return yaml.compose(text, Loader=_SAFE_LOADER)


class _DeepNode(Exception):
    """A node on the path MAX_DEPTH + 1 deep: a collection nested too deep, or a scalar in a
    collection just deep enough."""


class _BoundedLoader(_SAFE_LOADER):  # type: ignore[valid-type,misc]
    """The safe loader, stopping before it builds a node more than MAX_DEPTH deep.

    The composer (libyaml's too) calls ``descend_resolver`` before it builds each node and
    ``ascend_resolver`` after. The safe loader has no path resolvers, the one thing the base
    methods would follow, so these replace them (the second is a list's own ``pop``); and
    ``resolve``, which tags each plain scalar, looks its first character's resolvers up in a
    table made once.
    """

    def __init__(self, stream: str):
        super().__init__(stream)
        self._open: list[None] = []  # one per node being built: the depth
        # a C call for each node built, not a Python one (57,000 in a long motion: 0.01 s)
        self.ascend_resolver = self._open.pop

    def resolve(self, kind: type[Node], value: str | None, implicit: object) -> str:
        # BaseResolver.resolve without its path resolvers, and with the list of resolvers it
        # makes per scalar (those of the first character, then those of any) made once, here:
        # it runs for each of the 57,000 nodes of a long motion (0.17 -> 0.15 s of its YAML)
        if kind is yaml.ScalarNode and implicit[0]:  # type: ignore[index]  # a pair for scalars
            assert value is not None
            for tag, regexp in _RESOLVERS_BY_FIRST.get(value[:1], _RESOLVERS_OF_ANY):
                if regexp.match(value):
                    return tag
            return STR_TAG
        return super().resolve(kind, value, implicit)

    def descend_resolver(self, current_node: Node | None, current_index: object) -> None:
        self._open.append(None)
        if len(self._open) > MAX_DEPTH:
            raise _DeepNode


_RESOLVERS_OF_ANY = tuple(_BoundedLoader.yaml_implicit_resolvers.get(None, []))
_RESOLVERS_BY_FIRST = {
    first: tuple(resolvers) + _RESOLVERS_OF_ANY
    for first, resolvers in _BoundedLoader.yaml_implicit_resolvers.items()
    if first is not None
}


def _check_depth(path: Path, text: str) -> None:
    """``SourceError`` where the text opens its 65th level of lists or mappings.

    Newer libyaml (PyYAML 6.0.4) bounds the depth itself, but its scanner reads up to 1,024
    characters ahead, so it refuses a deep file at a later column and in its own words. When the
    fast parser fails, the pure-Python one (no bound of its own, and lazy) looks again for our
    bound first, so a user gets the same line, column and sentence whatever libyaml is installed.
    """
    try:
        _raise_if_too_deep(path, yaml.parse(text, Loader=_SAFE_LOADER))
    except yaml.YAMLError:
        if _SAFE_LOADER is yaml.SafeLoader:
            raise
        with contextlib.suppress(yaml.YAMLError):  # then the fast parser's error is the one
            _raise_if_too_deep(path, yaml.parse(text, Loader=yaml.SafeLoader))
        raise


def _raise_if_too_deep(path: Path, events: Iterable[yaml.Event]) -> None:
    depth = 0
    for event in events:
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                mark = event.start_mark
                line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
                raise SourceError(
                    f"{path}:{line}:{col}: nested more than {MAX_DEPTH} "
                    "lists or mappings deep; robot and motion files need a few levels"
                )
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1


def yaml_problem(error: yaml.YAMLError, text: str) -> tuple[int, int, str]:
    """Where (line, column) and what PyYAML found wrong in ``text``, in one line (its own
    message is several, with a picture of the line and ``in "<unicode string>"``)."""
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        problem = error.problem or error.context or "not YAML"
        if error.context and error.context_mark and error.problem:
            problem += f" ({error.context} at line {error.context_mark.line + 1})"
        return line, col, problem
    if isinstance(error, yaml.reader.ReaderError):  # a character YAML does not allow: no mark
        before = text[: error.position]
        line, col = before.count("\n") + 1, error.position - before.rfind("\n")
        code = error.character if isinstance(error.character, int) else ord(error.character)
        kind = "a control character" if code < 0x20 or 0x7F <= code < 0xA0 else "a character"
        return line, col, f"{kind} (U+{code:04X}) YAML does not allow; remove it"
    return 1, 1, next(iter(str(error).splitlines()), "") or type(error).__name__


def describe(node: Node) -> str:
    """What a node holds, in user words, for "got ..." in messages."""
    if isinstance(node, yaml.MappingNode):
        return "a mapping"
    if isinstance(node, yaml.SequenceNode):
        return "a list"
    if not node.tag.startswith("tag:yaml.org,2002:"):  # !foo 1: the tag is what is wrong
        return (
            f"{quoted(node.value)} with the tag {shortened(node.tag)} (remove the tag: these "
            "files use none)"
        )
    if node.tag == "tag:yaml.org,2002:null":
        return "nothing (null)"
    if node.tag == INT_TAG and len(node.value) > QUOTED_CHARS:  # maybe too long to read at all
        return f"a whole number {len(node.value)} digits long"
    lines = node.end_mark.line - node.start_mark.line + 1
    folded = getattr(node, "style", None) != "|"  # a scalar's; "|" keeps its newlines
    if node.tag == STR_TAG and folded and lines > 1 and len(node.value) > QUOTED_CHARS:
        # a long text over several lines (another kind of file, /etc/passwd): YAML joined them
        # with spaces; its first word is all a message quotes, as it is on the first line
        return f"a text over {lines} lines starting {repr(node.value.split(' ', 1)[0][:40])}…"
    return quoted(node.value) if node.tag == STR_TAG else shortened(node.value)


def plain_number(node: Node) -> float | None:
    """A finite number written plainly (``-12.5``, ``90``), read quickly, as ``Reader.number``
    reads it; ``None`` for anything else (a text, ``.inf``, ``0x1F``, ``012``, a mapping...),
    which ``Reader.number`` reads in full and reports. Nearly every value of a motion file is
    one: its poses are read through here."""
    if not isinstance(node, yaml.ScalarNode):  # (!!float [1] is a list)
        return None
    text = node.value
    if node.tag == FLOAT_TAG:
        try:
            value = float(text)
        except ValueError:  # .inf, .nan, 190:20:30 (base 60)
            return None
        return value if math.isfinite(value) else None  # 1.0e+999
    if node.tag == INT_TAG:
        digits = text[1:] if text.startswith(("-", "+")) else text
        # (0x1F, 0b1, 012 octal, 1_000, 3:25 base 60, 5,000 digits: read in full)
        if digits.isascii() and digits.isdigit() and (digits[0] != "0" or len(digits) == 1):
            return float(int(text)) if len(digits) <= 18 else None
    return None


class Reader:
    """Typed access to the nodes of one file; every refusal is reported with the node's place."""

    def __init__(self, path: Path, problems: Problems):
        self.path = path
        self.problems = problems
        self._constructor = yaml.constructor.SafeConstructor()

    def where(self, node: Node) -> SourceLocation:
        return SourceLocation(self.path, node.start_mark.line + 1, node.start_mark.column + 1)

    def report(self, node: Node, message: str) -> None:
        self.problems.add(self.where(node), message)

    def entries(self, node: Node, what: str) -> list[Entry] | None:
        """The ``key: value`` pairs of a mapping with string keys; duplicates are reported."""
        if not isinstance(node, yaml.MappingNode):
            self.report(node, f"{what} must be a mapping (key: value lines), got {describe(node)}")
            return None
        entries: dict[str, Entry] = {}
        for key_node, value in node.value:
            if not (isinstance(key_node, yaml.ScalarNode) and key_node.tag.endswith(":str")):
                self.report(key_node, f"{what}: keys must be names, got {describe(key_node)}")
            elif key_node.value in entries:
                first = entries[key_node.value].key_node.start_mark.line + 1
                self.report(
                    key_node,
                    f"{what}: {quoted(key_node.value)} is given twice (first at line {first}); "
                    "keep one",
                )
            else:
                entries[key_node.value] = Entry(key_node.value, key_node, value)
        return list(entries.values())

    def fields(
        self, node: Node, what: str, allowed: Sequence[str], required: Sequence[str] = ()
    ) -> dict[str, Entry] | None:
        """A mapping with a fixed set of keys: unknown keys and missing required keys reported."""
        entries = self.entries(node, what)
        if entries is None:
            return None
        known = {}
        for entry in entries:
            if entry.key in allowed:
                known[entry.key] = entry
            else:
                self.report(
                    entry.key_node,
                    f"unknown key {quoted(entry.key)} in {what}"
                    f"{did_you_mean(entry.key, allowed)}; valid keys: {', '.join(allowed)}",
                )
        for key in required:
            if key not in known:
                self.report(node, f"{what} is missing {key!r} (required)")
        return known

    def sequence(self, node: Node, what: str) -> list[Node] | None:
        if not isinstance(node, yaml.SequenceNode):
            self.report(
                node, f"{what} must be a list (lines starting with '- '), got {describe(node)}"
            )
            return None
        return list(node.value)

    def _scalar(self, node: Node) -> object:
        """The Python value of a scalar; the node itself for anything else (reported as such)."""
        if not isinstance(node, yaml.ScalarNode):
            return node
        if node.tag == FLOAT_TAG:  # most of a motion file: Python reads these as PyYAML does
            try:  # (not contextlib.suppress: this runs for every number of a file)
                return float(node.value)
            except ValueError:  # .inf, .nan, 1__0.5, 190:20:30 (base 60)
                pass
        try:
            return self._constructor.construct_object(node)
        # an unknown !tag; a whole number of more digits than Python reads (4,300)
        except (yaml.constructor.ConstructorError, ValueError):
            return node

    def number(
        self,
        node: Node,
        what: str,
        *,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        unit: str = "",
    ) -> float | None:
        """A finite number in [low, high] (``(low, high]`` with ``low_open``); ``unit`` (``" s"``)
        follows the range in messages."""
        value = self._scalar(node)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            valid = _range_words(low, high, low_open, unit)
            self.report(
                node, f"{what} must be a number{valid}, got {describe(node)}{_exponent_hint(node)}"
            )
            return None
        below = low is not None and (value <= low if low_open else value < low)
        if below or (high is not None and value > high):
            self.report(
                node, f"{what} must be{_range_words(low, high, low_open, unit)}, got {fmt(value)}"
            )
            return None
        return float(value)

    def integer(
        self, node: Node, what: str, *, low: int | None = None, high: int | None = None
    ) -> int | None:
        value = self._scalar(node)
        valid = _range_words(low, high, False)
        if isinstance(value, bool) or not isinstance(value, int):
            kind = "" if node.tag == INT_TAG else " a whole number"  # one too long to read
            self.report(node, f"{what} must be{kind}{valid}, got {describe(node)}")
            return None
        if (low is not None and value < low) or (high is not None and value > high):
            self.report(node, f"{what} must be{valid}, got {fmt(value)}")
            return None
        return value

    def boolean(self, node: Node, what: str) -> bool | None:
        value = self._scalar(node)
        if not isinstance(value, bool):
            self.report(node, f"{what} must be true or false, got {describe(node)}")
            return None
        return value

    def string(self, node: Node, what: str, *, optional: bool = False) -> str | None:
        """A non-empty text; with ``optional``, YAML null is accepted as ``None`` too."""
        if optional and node.tag == "tag:yaml.org,2002:null":
            return None
        value = self._scalar(node)
        if not isinstance(value, str) or not value:
            self.report(
                node, f"{what} must be a text{' or null' if optional else ''}, got {describe(node)}"
            )
            return None
        return value

    def choice(self, node: Node, what: str, choices: Sequence[str]) -> str | None:
        value = self.string(node, what)
        if value is not None and value not in choices:
            self.report(
                node,
                f"{what} {quoted(value)} is not one of {', '.join(choices)}"
                f"{did_you_mean(value, choices)}",
            )
            return None
        return value


# YAML 1.1 (what PyYAML reads) takes an exponent as a number only with a dot before it and a
# sign in it: 1.0e+12 is a number, 1e12 and 1.0e12 are text.
_TEXT_EXPONENT = re.compile(r"([-+]?[0-9]+)(\.[0-9]*)?[eE]([-+]?)([0-9]+)")


def _exponent_hint(node: Node) -> str:
    """`` (YAML reads 1e12 as text: write 1.0e+12)`` for a number YAML 1.1 leaves as text."""
    match = _TEXT_EXPONENT.fullmatch(str(node.value)) if isinstance(node, yaml.ScalarNode) else None
    if match is None or node.tag != STR_TAG or len(node.value) > QUOTED_CHARS:
        return ""
    whole, fraction, sign, exponent = match.groups()
    number = f"{whole}{fraction if fraction and fraction != '.' else '.0'}e{sign or '+'}{exponent}"
    return f" (YAML reads {node.value} as text: write {number})"


def _range_words(low: float | None, high: float | None, low_open: bool, unit: str = "") -> str:
    """`` in 0..1000``, `` in (0, 1]``, `` >= 0``, `` > 0`` (each followed by ``unit``), or
    ``""``."""
    if low is not None and high is not None:
        words = f" in ({fmt(low)}, {fmt(high)}]" if low_open else f" in {fmt(low)}..{fmt(high)}"
    elif low is not None:
        words = f" > {fmt(low)}" if low_open else f" >= {fmt(low)}"
    elif high is not None:
        words = f" <= {fmt(high)}"
    else:
        return ""
    return words + unit
