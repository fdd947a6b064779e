"""Finding a robot file: a robot is named (searched in ``models`` folders) or given by path."""

from __future__ import annotations

import os
from pathlib import Path

from choreo.core.file_kind import not_a_file
from choreo.core.yaml_source import did_you_mean, quoted

ROBOT_FILE = "robot.yaml"
REPO_MODELS = Path(__file__).resolve().parents[2] / "models"


def is_robot_path(ref: str | Path) -> bool:
    """A reference with a folder part or a .yaml ending is a path; anything else is a name."""
    text = str(ref)
    return (
        isinstance(ref, Path) or "/" in text or os.sep in text or text.endswith((".yaml", ".yml"))
    )


def robot_search_dirs(start: Path) -> list[Path]:
    """The existing ``models`` folders searched for a robot name, in order: ``start`` and its
    parents, then each folder of ``$CHOREO_MODELS`` (os.pathsep-separated), then the repo's."""
    start = start.resolve()
    candidates = [folder / "models" for folder in (start, *start.parents)]
    candidates += [Path(p) for p in os.environ.get("CHOREO_MODELS", "").split(os.pathsep) if p]
    candidates.append(REPO_MODELS)
    found: list[Path] = []
    for folder in candidates:
        if folder.is_dir() and folder.resolve() not in found:
            found.append(folder.resolve())
    return found


def known_robots(search_dirs: list[Path]) -> list[str]:
    return sorted({p.parent.name for folder in search_dirs for p in folder.glob(f"*/{ROBOT_FILE}")})


def find_robot_file(ref: str | Path, relative_to: Path | None = None) -> Path:
    """The robot.yaml that ``ref`` names; ``LookupError`` saying what was searched otherwise.

    ``relative_to`` is the file that names the robot (a motion file): a path is relative to its
    folder, and a name is searched from its folder up. Without it, from the working directory.
    """
    base = relative_to.parent if relative_to is not None else Path()
    if is_robot_path(ref):
        path = Path(os.path.normpath(base / ref))  # "parts/../models/x" reads badly in messages
        path = path / ROBOT_FILE if path.is_dir() else path
        kind = not_a_file(path)
        if kind is not None:
            raise LookupError(f"robot file {str(ref)!r} is {kind}, not a robot file")
        if not path.is_file():
            raise LookupError(f"robot file {str(ref)!r} not found (looked for {path})")
        return path
    name = str(ref)  # a name (a Path is always a path, above)
    search_dirs = robot_search_dirs(base)
    for folder in search_dirs:
        if (folder / name / ROBOT_FILE).is_file():
            return folder / name / ROBOT_FILE
    known = known_robots(search_dirs)
    raise LookupError(
        f"unknown robot {quoted(name)}{did_you_mean(name, known)}; known robots: "
        f"{', '.join(known) or 'none'} (looked for <name>/{ROBOT_FILE} in "
        f"{', '.join(map(str, search_dirs)) or 'no models folder'}; "
        f"set CHOREO_MODELS to add a folder, or give a path to a {ROBOT_FILE})"
    )
