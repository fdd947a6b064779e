"""Every module, file and name that a doc, docstring or comment points to exists.

A stale pointer (``choreo/realtime.py`` after the module moved) sends a newcomer looking for a
room that is gone. Pointers are read from the Markdown files (less the README's table of old
names) and from the docstrings and comments of every Python file of the package, the tests and
the benchmarks, in three forms: a path (``choreo/play/player.py``), a dotted name
(``choreo.play.player.Player``) and a module's file name in backquotes (```player.py```), which
must name a file of the repository or a module that imports.
"""

from __future__ import annotations

import ast
import importlib.util
import io
import re
import tokenize
import tomllib
from functools import cache
from pathlib import Path

import pytest
from paths import REPO

DOCS = sorted([*REPO.glob("*.md"), *(REPO / "docs").glob("*.md")])
SOURCES = sorted(
    path
    for folder in ("choreo", "tests", "benchmarks")
    for path in (REPO / folder).rglob("*.py")
    if path.name != Path(__file__).name  # this file's examples of stale pointers are on purpose
)
PATH = re.compile(r"\bchoreo/[\w/.-]*\w/?(?![\w<*/])")  # not a key pattern: choreo/x/<name>
DOTTED = re.compile(r"(?<![\w/.])choreo(?:\.\w+)+")
FILE_NAME = re.compile(r"`(\w+)\.py`")
# where a module defines a name: def, class, assignment, import, or a public table's string
DEFINED = (
    r"^\s*(?:def|class|async def)\s+{0}\b|^\s*{0}\s*[:=]|^(?:from .* )?import .*\b{0}\b"
    r"|^\s+{0},|\"{0}\""
)
OLD_NAMES = re.compile(r"^### Changes for code.*?(?=^##? |\Z)", re.MULTILINE | re.DOTALL)


@cache
def repo_file_names() -> frozenset[str]:
    tracked = [*SOURCES, *(REPO / ".ci").iterdir()]
    return frozenset(path.name for path in tracked)


def prose(path: Path) -> str:
    """What a file says to a reader: a Markdown file less its table of old names; a Python
    file's comments and docstrings."""
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".md":
        return OLD_NAMES.sub("", text)
    comments = []
    if COMMENT_WITH_A_POINTER.search(text):  # tokenizing is most of this test's CPU: 45 of 430
        tokens = tokenize.generate_tokens(io.StringIO(text).readline)
        comments = [token.string for token in tokens if token.type == tokenize.COMMENT]
    return "\n".join([*comments, *docstrings(ast.parse(text))])


DOCUMENTED = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)
# a comment is one line: one with a pointer has "#" and, after it on its line, "choreo" (a path or
# a dotted name) or ".py`" (a file name); a file without such a line has no comment to read
COMMENT_WITH_A_POINTER = re.compile(r"#.*(?:choreo|\.py`)")
BODIES = ("body", "orelse", "finalbody", "handlers", "cases")  # the fields holding statements


def docstrings(tree: ast.Module) -> list[str]:
    """The docstrings of the module and of every class and function in it, however nested.
    Only statements are visited (ast.walk's every expression cost twice this test's CPU): a
    docstring is the first statement of a module, class or function body, and those are
    statements themselves, or in a statement's body, branches or handlers."""
    found, statements = [], [tree]
    while statements:
        node = statements.pop()
        if isinstance(node, DOCUMENTED):
            found.append(ast.get_docstring(node, clean=False) or "")
        for field in BODIES:
            children = getattr(node, field, None)
            if isinstance(children, list):
                statements.extend(children)
    return found


def module_file(parts: list[str]) -> Path | None:
    """The file of the module ``choreo.<parts>``, if there is one."""
    path = REPO.joinpath("choreo", *parts)
    for candidate in (path.with_suffix(".py"), path / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@cache
def entry_point_groups() -> frozenset[str]:
    """The entry-point groups pyproject.toml declares (``choreo.backends``): dotted, not modules."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return frozenset(project.get("entry-points", {}))


@cache
def stale_dotted(name: str) -> str | None:
    """Why ``choreo.a.b.Name`` points nowhere (None if it resolves): the longest prefix that is a
    module must define the first name after it (as a function, class, assignment or import), or
    the name is an entry-point group of pyproject.toml."""
    if name in entry_point_groups():
        return None
    parts = name.split(".")[1:]
    if not parts or parts[0].startswith("__"):
        return None
    for split in range(len(parts), -1, -1):
        module = module_file(parts[:split])
        if module is None:
            continue
        rest = parts[split:]
        if not rest or rest[0].startswith("__"):
            return None
        pattern = re.compile(DEFINED.format(re.escape(rest[0])), re.MULTILINE)
        if pattern.search(module.read_text(encoding="utf-8")):
            return None
        return f"{name}: {module.relative_to(REPO)} defines no {rest[0]}"
    return f"{name}: no module choreo.{parts[0]}"


def stale_pointers(text: str) -> list[str]:
    found = []
    for match in PATH.finditer(text):
        target = REPO / match[0]
        if not target.exists() and not target.with_suffix(".py").is_file():
            found.append(f"{match[0]}: no such file or folder")
    for match in DOTTED.finditer(text):
        why = stale_dotted(match[0].rstrip("."))
        if why:
            found.append(why)
    for match in FILE_NAME.finditer(text):
        name = f"{match[1]}.py"
        if name not in repo_file_names() and importlib.util.find_spec(match[1]) is None:
            found.append(f"{name}: no file of that name")
    return found


def folders() -> dict[str, list[Path]]:
    """The files read, by folder (``docs``, ``choreo/music``...): a test a folder, not a file,
    as 440 tests' own overhead was half this file's CPU."""
    by_folder: dict[str, list[Path]] = {}
    for path in [*DOCS, *SOURCES]:
        by_folder.setdefault(str(path.parent.relative_to(REPO)), []).append(path)
    return by_folder


def stale_in_prose(path: Path) -> list[str]:
    """The stale pointers in what ``path`` says to a reader (``prose``). A Python file is read
    whole first: its comments and docstrings are pieces of it, so where nothing in all of it
    points nowhere (its code's paths and names included), nothing in them does, and parsing it
    for them (four fifths of this test's CPU) is skipped. Each pointer is found alike in a piece
    and in the whole: none spans a line, and what the patterns look at either side of one (the
    comment's "#", a docstring's quotes or the line joining the pieces) is no word character."""
    if path.suffix == ".py" and not stale_pointers(path.read_text(encoding="utf-8")):
        return []
    return stale_pointers(prose(path))


@pytest.mark.parametrize(("folder", "paths"), folders().items(), ids=list(folders()))
def test_every_pointer_in_a_file_points_to_something(folder, paths):
    stale = {str(path.relative_to(REPO)): stale_in_prose(path) for path in paths}
    assert {path: pointers for path, pointers in stale.items() if pointers} == {}


def test_a_stale_pointer_is_found():
    """The check itself: a moved module, a renamed class, a vanished file and a misspelt
    entry-point group are each caught."""
    text = (
        "see choreo/realtime.py, choreo.play.player.NoSuchPlayer, `soundtrack2.py`, "
        "choreo.backend;\n"
        "fine: choreo/play/player.py, choreo.play.player.Player, `player.py`, choreo/bus/, "
        "choreo.backends\n"
    )
    assert stale_pointers(text) == [
        "choreo/realtime.py: no such file or folder",
        "choreo.play.player.NoSuchPlayer: choreo/play/player.py defines no NoSuchPlayer",
        "choreo.backend: choreo/__init__.py defines no backend",
        "soundtrack2.py: no file of that name",
    ]
