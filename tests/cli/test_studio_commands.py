"""choreo studio's command line: the listen address, and one line for a motion that is not there."""

from __future__ import annotations

import pytest

from choreo.cli import main
from choreo.cli.studio_commands import listen_address


def test_the_listen_address_is_host_and_port():
    assert listen_address("127.0.0.1:8080").url == "http://127.0.0.1:8080/"
    assert listen_address("[::1]:9000").url == "http://[::1]:9000/"
    with pytest.raises(Exception, match="HOST:PORT"):
        listen_address("8080")


def test_a_missing_motion_file_is_one_line(tmp_path, capsys):
    assert main(["studio", str(tmp_path / "none.yaml")]) == 2
    assert (
        capsys.readouterr().err == f"choreo: error: {tmp_path / 'none.yaml'}: no such motion file\n"
    )
