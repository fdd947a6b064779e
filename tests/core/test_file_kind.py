"""choreo.core.file_kind: what sits where a file belongs, and OS errors in plain words."""

from __future__ import annotations

import errno
import os
import socket
from pathlib import Path

from choreo.cli import main
from choreo.core.file_kind import not_a_file, os_error_text


def test_each_kind_of_non_file_is_named(tmp_path):
    regular = tmp_path / "wave.yaml"
    regular.write_text("a: 1\n")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    (tmp_path / "loop").symlink_to("loop")
    (tmp_path / "to_file").symlink_to("wave.yaml")
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(tmp_path / "sock"))
        assert not_a_file(tmp_path / "sock") == "a socket"
    assert not_a_file(regular) is None and not_a_file(tmp_path / "to_file") is None
    assert not_a_file(tmp_path / "missing") is None  # the caller says "does not exist"
    assert not_a_file(tmp_path) == "a folder"
    assert not_a_file(fifo) == "a FIFO (named pipe)"
    assert not_a_file("/dev/null") == "a device"
    assert not_a_file(tmp_path / "loop") == "a loop of symbolic links"


def test_an_os_error_reads_as_one_plain_phrase():
    error = IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), "motions")
    assert os_error_text(error) == "motions: is a directory"
    assert os_error_text(OSError(errno.EIO, os.strerror(errno.EIO))) == "input/output error"


def test_an_os_error_reaching_the_command_line_has_no_errno(monkeypatch, capsys):
    def fail(args):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(Path("out")))

    monkeypatch.setattr("choreo.cli.robot_commands.run_robots", fail)  # read by the parser
    assert main(["robots"]) == 1
    assert capsys.readouterr().err == "choreo: error: out: is a directory\n"
