"""Writing files so that readers never see half of one and a crash loses nothing once written."""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

from choreo.core.file_kind import not_a_file
from choreo.errors import ChoreoError


@contextlib.contextmanager
def atomic_output(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it replaces ``path`` only when the block
    finishes without an exception (Ctrl-C included), so readers never see a half-written file
    and a good old one is never lost. The temporary ends in ``path``'s suffix, for writers that
    choose a format by it. A symbolic link is written through (the file it points to is
    replaced, the link stays); anything but a regular file is refused (``check_writable``). The
    new file gets the permissions of any new file (0666 less the umask), not mkstemp's 0600. The
    data and the new name are flushed to disk before returning (a crash right after loses
    nothing)."""
    check_writable(path)
    target = write_target(Path(path))
    with _temporary(target) as temporary:
        yield temporary
        with open(temporary, "rb") as written:
            os.fsync(written.fileno())
        os.chmod(temporary, 0o666 & ~current_umask())
        os.replace(temporary, target)
        fsync_directory(target.parent)


def write_target(path: Path) -> Path:
    """The file a write to ``path`` replaces: a symbolic link's target (followed to the end),
    else ``path`` itself."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def check_writable(path: Path, *, overwrite: bool = True) -> None:
    """``ChoreoError`` if ``path`` cannot be written: it is not a regular file (a folder, a
    FIFO, a device), its name is too long, its folder is missing or does not take new files, or
    (without ``overwrite``) it exists. Commands call it before their work, so nothing is
    computed for an output that would fail at the end."""
    path = Path(path)
    _check_name_length(path)
    target = write_target(path)
    kind = not_a_file(target)
    if kind is not None:
        raise ChoreoError(f"cannot write {path}: it is {kind}, not a file")
    folder = target.parent
    if not folder.is_dir():
        raise ChoreoError(f"cannot write {path}: the folder {folder} does not exist")
    _check_name_length(target)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ChoreoError(f"cannot write {path}: the folder {folder} is not writable")
    if not overwrite and path.exists():
        raise ChoreoError.naming(
            "overwrite", f"{path} exists: choose another file, or allow replacing it ({{option}})"
        )
    try:  # the only sure test (root passes os.access, yet /proc takes no new files)
        with _temporary(target):
            pass
    except OSError as error:
        raise ChoreoError(
            f"cannot write {path}: the folder {folder} does not take new files "
            f"({(error.strerror or str(error)).lower()})"
        ) from None


def _check_name_length(path: Path) -> None:
    longest = _longest_name(path.parent)
    if len(os.fsencode(path.name)) > longest:
        raise ChoreoError(
            f"cannot write {path}: the name is {len(os.fsencode(path.name))} bytes long, the "
            f"most a file name can be here is {longest}"
        )


@contextlib.contextmanager
def _temporary(target: Path) -> Iterator[Path]:
    """A new empty file ``.NAME.RANDOM.tmpSUFFIX`` beside ``target``, gone again when the block
    ends unless the block renamed it. The name is chosen before the file is made (mkstemp
    returns it only after), so a Ctrl-C at any moment leaves nothing behind; 64 random bits
    keep it from ever being another file's."""
    temporary = _temporary_name(target)
    try:
        os.close(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        yield temporary
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)


_RANDOM_DIGITS = 16
_RANDOM_AND_TMP = len(f".{'0' * _RANDOM_DIGITS}.tmp")  # what follows the name


def _temporary_name(target: Path) -> Path:
    """``.NAME.RANDOM.tmpSUFFIX`` beside ``target``, NAME shortened so the whole stays within
    the file system's longest name."""
    suffix = target.suffix if len(os.fsencode(target.suffix)) <= 16 else ""
    room = _longest_name(target.parent) - _RANDOM_AND_TMP - 1 - len(os.fsencode(suffix))
    name = os.fsencode(target.name)[:room].decode(errors="ignore")  # whole characters only
    return target.parent / f".{name}.{secrets.token_hex(_RANDOM_DIGITS // 2)}.tmp{suffix}"


def _longest_name(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):  # Windows has no pathconf; NTFS allows 255
        return 255


def write_text_atomically(path: Path, text: str) -> None:
    with atomic_output(path) as temporary:
        temporary.write_text(text, encoding="utf-8")


def current_umask() -> int:
    mask = os.umask(0o022)  # the only way to read it is to set it: put it straight back
    os.umask(mask)
    return mask


def fsync_directory(folder: Path) -> None:
    """Make a new or renamed file's name durable."""
    if os.name != "posix":
        return  # Windows cannot open a folder for fsync; NTFS journals its metadata
    handle = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)
