"""choreo.bus.transports: a port string picks its backend, and a port that cannot be opened says
the real cause."""

from __future__ import annotations

import os

from cli_helpers import error_line

from choreo.cli import main

LIST_PORTS = "list ports with `choreo ports`; `sim://` is the built-in emulator"


def scan_error(capsys, port: str) -> str:
    assert main(["scan", "--port", port, "--ids", "1"]) == 1
    return error_line(capsys)


def test_a_missing_port_is_not_called_busy(capsys):
    assert scan_error(capsys, "/dev/ttyNOPE") == (
        f"choreo: error: cannot open /dev/ttyNOPE: no such port; {LIST_PORTS}"
    )


def test_a_file_that_is_not_a_port_says_so(tmp_path, capsys):
    plain = tmp_path / "notes.txt"
    plain.write_text("not a tty")
    assert scan_error(capsys, str(plain)) == (
        f"choreo: error: cannot open {plain}: it is not a serial port; {LIST_PORTS}"
    )


def test_only_a_busy_port_asks_about_another_program(capsys):
    import pty

    import serial

    master, slave = pty.openpty()
    name = os.ttyname(slave)
    try:
        with serial.Serial(name, exclusive=True):  # another program holds it
            assert scan_error(capsys, name) == (
                f"choreo: error: cannot open {name}: the port is busy. Is another program using it?"
            )
    finally:
        os.close(master)
        os.close(slave)
