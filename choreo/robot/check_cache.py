"""Model checks that passed before, remembered so that reading a robot file does not import
MuJoCo (some 0.2 s of every ``choreo plan``) to check a model that has not changed.

A passed check is remembered under a digest of everything it depends on: the robot file, every
file in the model's and the scene's folders (the XML and YAML files by content, the others,
meshes and textures, by size and time of change), the code that reads robot files and checks
models, and the installed MuJoCo. Files are named from the robot file's folder, so the same
files elsewhere find the check passed (a performer stages each part's robot in a new folder).
Only passes are remembered, so a problem is found and reported again every time; a model that
names a file outside its folders is never remembered (its files are not all known here). The
cache is ``$CHOREO_CACHE_DIR``, else ``$XDG_CACHE_HOME/choreo``, else ``~/.cache/choreo``; where
it cannot be read or written, the check simply runs.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import logging
import os
import re
from pathlib import Path

log = logging.getLogger(__name__)

CACHE_VERSION = b"1"
MODEL_CHECKS = "model-checks"  # the cache's folder of passed model checks
MAX_FOLDER_FILES = 1000  # beyond this a folder is not a robot's model folder: not remembered
_CONTENT_SUFFIXES = (".xml", ".yaml", ".yml")  # small, edited by hand: keyed by content
# A file a model names: an <include file=...>, an asset, or an asset folder.
_NAMED_FILE = re.compile(rb"""\b(?:file|meshdir|texturedir|assetdir)\s*=\s*["']([^"']*)["']""")
_CODE = Path(__file__).parent  # choreo.robot: reads robot files and checks models


def check_key(robot_path: Path, model_paths: list[Path]) -> str | None:
    """The digest a passed check of ``robot_path`` with ``model_paths`` (its MJCF and scene) is
    remembered under; None if it cannot be remembered (a file named outside the folders, a
    folder too big to be a model's, no MuJoCo, a file that cannot be read)."""
    digest = hashlib.sha256(CACHE_VERSION)
    robot_path = Path(robot_path).resolve()
    try:
        _add_mujoco(digest)
        _add_content(digest, robot_path, robot_path.parent)
        for code in sorted(_CODE.glob("*.py")):
            _add_content(digest, code, _CODE)
        for folder in sorted({Path(p).parent.resolve() for p in model_paths}):
            if not _add_folder(digest, folder, robot_path.parent):
                return None
    except (OSError, LookupError) as error:
        log.debug("model check not remembered: %s", error)
        return None
    return digest.hexdigest()


def remembered(key: str) -> bool | None:
    """Whether the robot is free-floating, as the passed check under ``key`` found; None if
    no check passed under it."""
    return {"free": True, "fixed": False}.get(recall(MODEL_CHECKS, key) or "")


def remember(key: str, free_floating: bool) -> None:
    """Remember that the check under ``key`` passed (best effort: a cache that cannot be
    written is skipped)."""
    keep(MODEL_CHECKS, key, "free" if free_floating else "fixed")


def recall(kind: str, key: str) -> str | None:
    """What was kept under ``key`` among the ``kind`` (a folder of the cache), or None."""
    try:
        return (_folder(kind) / key).read_text(encoding="ascii")
    except (OSError, ValueError):
        return None


def keep(kind: str, key: str, text: str) -> None:
    """Keep ``text`` (ASCII) under ``key`` among the ``kind``; best effort: a cache that cannot
    be written is skipped. Also what the preview's gait calibration remembers its figures by."""
    folder = _folder(kind)
    temporary = folder / f".{key}.{os.getpid()}"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        temporary.write_text(text, encoding="ascii")
        os.replace(temporary, folder / key)  # whole or absent for a reader at the same time
    except OSError as error:
        log.debug("%s not remembered in %s: %s", kind, folder, error)
        with contextlib.suppress(OSError):
            temporary.unlink(missing_ok=True)


def forget(kind: str, key: str) -> None:
    """Forget what was kept under ``key`` among the ``kind``, if anything (best effort)."""
    with contextlib.suppress(OSError):
        (_folder(kind) / key).unlink(missing_ok=True)


def _folder(kind: str) -> Path:
    explicit = os.environ.get("CHOREO_CACHE_DIR")
    if explicit:
        return Path(explicit) / kind
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "choreo" / kind


def _add_mujoco(digest: hashlib._Hash) -> None:
    """The installed MuJoCo (found, not imported: importing it is what the cache saves)."""
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.origin is None:
        raise LookupError("MuJoCo is not installed")
    stat = os.stat(spec.origin)
    digest.update(f"{spec.origin}\0{stat.st_size}\0{stat.st_mtime_ns}\0".encode())


def _add_content(digest: hashlib._Hash, path: Path, base: Path) -> None:
    digest.update(f"{_relative(path, base)}\0".encode())
    digest.update(hashlib.sha256(path.read_bytes()).digest())


def _add_folder(digest: hashlib._Hash, folder: Path, base: Path) -> bool:
    """Every file in ``folder`` and below, named from ``base`` (the robot file's folder); False
    if one of its models names a file outside it or it holds too many files to be a model's
    folder."""
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    if len(files) > MAX_FOLDER_FILES:
        return False
    for path in files:
        name = _relative(path, base)
        if path.suffix.lower() not in _CONTENT_SUFFIXES:
            stat = path.stat()
            digest.update(f"{name}\0{stat.st_size}\0{stat.st_mtime_ns}\0".encode())
            continue
        data = path.read_bytes()
        if path.suffix.lower() == ".xml" and _names_outside(data):
            return False
        digest.update(f"{name}\0".encode())
        digest.update(hashlib.sha256(data).digest())
    return True


def _relative(path: Path, base: Path) -> str:
    """``path`` as named from ``base``: the key does not change with where the robot's files
    are, only with what they hold and how they lie to each other (a performer stages each part's
    robot in a new folder, and so finds the check its copy of the same files passed before)."""
    try:
        return Path(os.path.relpath(path, base)).as_posix()
    except ValueError:  # on another drive (Windows): named in full
        return str(path)


def _names_outside(xml: bytes) -> bool:
    """The model names a file by an absolute path or one climbing out of its folder."""
    for name in _NAMED_FILE.findall(xml):
        parts = name.replace(b"\\", b"/").split(b"/")
        if name.startswith((b"/", b"~")) or b".." in parts or re.match(rb"[A-Za-z]:", name):
            return True
    return False
