"""choreo.core.atomic: a file is replaced whole or not at all, and no temporary file is left
behind."""

from __future__ import annotations

import os
import stat

import pytest

from choreo.core.atomic import atomic_output, fsync_directory, write_text_atomically
from choreo.errors import ChoreoError


def test_write_text_replaces_the_file_whole_and_leaves_nothing_else(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text("old\n")
    write_text_atomically(path, "keyframes: []  # 30°\n")
    assert path.read_bytes() == "keyframes: []  # 30°\n".encode()
    assert [p.name for p in tmp_path.iterdir()] == ["wave.yaml"]


def test_a_failed_write_keeps_the_old_file_and_removes_the_temporary(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text("old\n")
    with pytest.raises(RuntimeError, match="disk full"):
        with atomic_output(path) as temporary:
            temporary.write_text("half a fi")
            raise RuntimeError("disk full")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["wave.yaml"]


def test_the_temporary_is_beside_the_target_so_the_rename_is_atomic(tmp_path):
    path = tmp_path / "wave.yaml"
    with atomic_output(path) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".wave.yaml.")
        temporary.write_bytes(b"\x00\x01")
    assert path.read_bytes() == b"\x00\x01"


def test_fsync_directory_accepts_a_folder(tmp_path):
    fsync_directory(tmp_path)  # raises OSError if the folder cannot be opened
    with pytest.raises(FileNotFoundError):
        fsync_directory(tmp_path / "missing")


def test_a_missing_folder_is_a_clear_error_naming_it(tmp_path):
    with pytest.raises(
        ChoreoError,
        match=r"cannot write .*nowhere/x.yaml: the folder .*nowhere "
        r"does not exist",
    ):
        write_text_atomically(tmp_path / "nowhere" / "x.yaml", "a: 1\n")


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_written_file_respects_the_umask(tmp_path, umask, mode):
    path = tmp_path / "wave.yaml"
    previous = os.umask(umask)
    try:
        write_text_atomically(path, "keyframes: []\n")
    finally:
        os.umask(previous)
    assert stat.S_IMODE(path.stat().st_mode) == mode


def test_the_temporary_keeps_the_suffix_writers_choose_a_format_by(tmp_path):
    with atomic_output(tmp_path / "keep.mp4") as temporary:
        assert temporary.suffix == ".mp4"
        temporary.write_bytes(b"video")
