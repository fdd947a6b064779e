"""choreo.bus.transports: a port string picks its backend, every backend keeps one contract (bus/'s
own, the emulator's and a package's, added through an entry point), and a port that cannot be
opened says the real cause."""

from __future__ import annotations

import os
import sys

import pytest
import serial
from cli_helpers import error_line

from choreo.bus import transports
from choreo.bus.servo_bus import ServoBus
from choreo.bus.transports import lobot, raw
from choreo.cli import main
from choreo.emulator import backend as emulator_backend

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


# --- the backend contract ----------------------------------------------------------------------
MOVES = [(1, 500), (2, 300), (3, 700)]


class WrittenPort:
    """An open port that keeps what is written."""

    name, timeout, in_waiting = "written", 0.01, 0

    def __init__(self):
        self.written = bytearray()

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def flush(self) -> None: ...

    reset_input_buffer = reset_output_buffer = close = flush


@pytest.mark.parametrize(
    ("port", "transport"),
    [
        ("/dev/ttyUSB0", "raw LX bus"),
        ("loop://", "raw LX bus"),
        ("rrc:///dev/ttyAMA0", "RRC board"),
        ("lobot:///dev/ttyUSB0", "LOBOT controller"),
        ("lobot://hid?report_ms=32", "LOBOT controller"),
        ("sim://?ids=1-3", "raw LX bus"),
        ("sim://?board=rrc", "RRC board"),
        ("SIM://?board=lobot", "LOBOT controller"),
    ],
)
def test_every_backend_keeps_the_contract(port, transport):
    """Each scheme's backend is a Transport; its link, found without opening anything, makes a
    backend whose move_many writes exactly the link's move frame."""
    backend = transports.transport_for(port)
    assert isinstance(backend, transports.Transport)
    link = transports.link(port)
    assert link.capabilities.transport == transport
    written = WrittenPort()
    speaker = link.backend_on(written)
    assert speaker.capabilities == link.capabilities
    assert speaker.move_many(MOVES, 40) == len(link.move_frame(MOVES, 40))
    assert bytes(written.written) == link.move_frame(MOVES, 40)


def test_the_bus_finds_sim_through_choreo_s_entry_point_not_by_importing_it():
    entry = transports.added_backends()["sim"]
    assert (entry.value, entry.dist.name) == ("choreo.emulator.backend", "choreo")
    assert "sim" not in transports.BACKENDS
    assert transports.transport_for("sim://") is emulator_backend


def test_lobot_hid_link_has_the_report_interval_of_its_url():
    assert transports.link("lobot://hid?report_ms=32").capabilities.host_byte_time_s == (
        pytest.approx(0.032 / lobot.HID_REPORT)
    )


FAKE_BOARD = '''
"""A third party's board: its own scheme, here the emulator's servos behind it."""
from choreo.bus.transports import raw
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection

opened = []


def connect(port, timeout_s, direction, echo):
    opened.append(port)
    ids = [int(i) for i in port.split("://", 1)[1].split(",")]
    return connection(BusEmulator(ids, clock=VirtualClock()), timeout_s)


def link(port):
    return raw.LINK
'''


@pytest.fixture
def installed(tmp_path, monkeypatch):
    """Install a package on sys.path as pip would: its module and its dist-info with entry
    points; the backends are read again with it, and again once it is gone."""

    def install(package: str, entry_points: str, module: str | None = None) -> None:
        info = tmp_path / f"{package}-1.0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: 1.0\n")
        (info / "entry_points.txt").write_text(f"[choreo.backends]\n{entry_points}\n")
        if module is not None:
            (tmp_path / f"{package}.py").write_text(module)
        monkeypatch.syspath_prepend(str(tmp_path))
        monkeypatch.delitem(sys.modules, package, raising=False)
        transports.added_backends.cache_clear()

    yield install
    transports.added_backends.cache_clear()


def test_a_package_adds_a_board_through_an_entry_point(installed, capsys):
    installed("fakeboard", "fake = fakeboard", FAKE_BOARD)
    with ServoBus("fake://4,7", retries=0) as bus:
        assert bus.scan(range(10)) == [4, 7]
    assert sys.modules["fakeboard"].opened == ["fake://4,7"]
    assert transports.link("fake://4,7") is raw.LINK
    assert main(["scan", "--port", "fake://2", "--ids", "1-3"]) == 0
    assert "1 servo(s) on fake://2" in capsys.readouterr().out


def test_an_unknown_scheme_is_one_line_naming_the_schemes_there_are(capsys):
    assert scan_error(capsys, "rcc:///dev/ttyAMA0") == (
        "choreo: error: rcc:///dev/ttyAMA0: no backend for rcc://; there are rrc://, lobot://, "
        "sim:// (choreo), a device path and the URLs pyserial opens (loop://, socket://, "
        "rfc2217://); a package adds one with an entry point in the choreo.backends group"
    )


def test_sim_missing_from_choreo_s_entry_points_says_to_reinstall(monkeypatch, capsys):
    monkeypatch.setattr(transports, "added_backends", dict)  # a stale install: no entry points
    # nor has this process told pyserial where sim:// is (it would open it as a plain URL)
    monkeypatch.setattr(serial, "protocol_handler_packages", ["serial.urlhandler"])
    assert scan_error(capsys, "sim://?ids=1") == (
        "choreo: error: sim://?ids=1: no backend for sim://; there are rrc://, lobot://, a device "
        "path and the URLs pyserial opens (loop://, socket://, rfc2217://); sim:// comes with "
        "choreo (its emulator) through its entry points, which this Python does not see: "
        "reinstall choreo (in a checkout: pip install -e .)"
    )


@pytest.mark.parametrize(
    ("entry", "module", "says"),
    [
        ("gone = nosuchboard", None, "cannot be loaded: No module named 'nosuchboard'"),
        (
            "gone = notaboard",
            "connect = None\n",
            "does not keep choreo's contract: it provides no connect() and link() "
            "(choreo.bus.transports.Transport)",
        ),
    ],
)
def test_a_broken_backend_of_a_package_is_one_line_naming_it(
    installed, capsys, entry, module, says
):
    name = entry.split(" = ")[1]
    installed(name, entry, module)
    line = scan_error(capsys, "gone://x")
    assert line.startswith(f"choreo: error: gone://x: the gone:// backend {name} (package {name}) ")
    assert line.endswith(says)
