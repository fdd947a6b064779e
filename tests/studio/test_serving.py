"""Where the studio serves its page: a wrong --listen is one line and exit 1 before anything
loads, a port named is used or refused (never moved), and what a page sends that the server
cannot read is one line, not a traceback."""

from __future__ import annotations

import asyncio
import contextlib
import shutil
import socket
import urllib.request
from pathlib import Path

import msgspec
import pytest
import viser
import websockets
from emulated import WAIT_S, wait_for

from choreo.cli import main
from choreo.cli.studio_commands import listen_address
from choreo.errors import ChoreoError
from choreo.studio.address import Address
from choreo.studio.server import Studio
from choreo.studio.serving import port_to_serve

WAVE = Path(__file__).parents[2] / "motions" / "arm6" / "wave.yaml"


@pytest.fixture
def taken_port():
    """A port another server listens on."""
    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        yield other.getsockname()[1]


def test_the_listen_address_names_a_port_or_leaves_it_to_the_studio():
    assert listen_address("127.0.0.1:8080") == Address("127.0.0.1", 8080)
    assert listen_address("[::1]:0") == Address("::1", 0)  # any free port
    assert listen_address("0.0.0.0") == Address("0.0.0.0", 8080, next_free=True)
    assert listen_address("[::1]") == Address("::1", 8080, next_free=True)
    for wrong in ("8080", ":8080", "host:99999", "host:http"):
        with pytest.raises(Exception, match="HOST:PORT"):
            listen_address(wrong)


@pytest.mark.parametrize(
    ("host", "why"),
    [
        ("999.1.1.1", "not an address this computer can serve on"),
        ("no-such-host.invalid", "not an address this computer can serve on"),
        ("192.0.2.1", "cannot serve there"),  # TEST-NET-1: resolves, is nobody's here
    ],
)
def test_an_address_the_studio_cannot_serve_on_is_one_line_and_exit_1(host, why, capsys):
    assert main(["studio", str(WAVE), "--listen", f"{host}:8080"]) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith(f"choreo: error: --listen {host}: {why}")
    assert err.count("\n") == 1


def test_a_port_named_that_is_taken_is_an_error_and_only_the_default_moves_on(taken_port, capsys):
    assert main(["studio", str(WAVE), "--listen", f"127.0.0.1:{taken_port}"]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: --listen 127.0.0.1:{taken_port}: the port is taken (another studio, or "
        "another server); give another port, or 127.0.0.1:0 for any free one\n"
    )
    with pytest.raises(ChoreoError, match="^listen 127.0.0.1:"):  # the library's own word
        Studio(WAVE, Address("127.0.0.1", taken_port), say=print)
    assert port_to_serve(Address("127.0.0.1", taken_port, next_free=True)) > taken_port
    assert port_to_serve(Address("127.0.0.1", 0)) == 0  # the server takes any free one


def test_the_page_and_the_timeline_are_all_on_the_one_address_and_close_with_the_studio(
    tmp_path,
):
    motion = tmp_path / "wave.yaml"
    shutil.copy(WAVE, motion)
    studio = Studio(motion, Address("127.0.0.1", 0), say=lambda line: None)
    behind = [studio.server.get_port(), studio.timeline_page.port]
    assert studio.server.get_host() == "127.0.0.1"  # viser: loopback, on a port of its own
    assert studio.address.port not in behind
    studio.start()
    url = studio.address.url
    try:
        with urllib.request.urlopen(url) as page:  # viser's page
            assert b"<html" in page.read()
        with urllib.request.urlopen(f"{url}timeline/") as timeline:
            assert b"<canvas" in timeline.read()
        play = urllib.request.Request(f"{url}timeline/command", data=b'{"op":"play"}')
        with urllib.request.urlopen(play) as answer:
            assert answer.status == 204
        wait_for(lambda: studio.playing, "the play the timeline asked for")
    finally:
        studio.close()
    for port in (studio.address.port, *behind):
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", port), timeout=2.0).close()


def test_a_message_the_server_cannot_read_is_one_line_not_a_traceback(tmp_path, capfd, caplog):
    motion = tmp_path / "wave.yaml"
    shutil.copy(WAVE, motion)
    said: list[str] = []
    studio = Studio(motion, Address("127.0.0.1", 0), say=said.append)
    studio.start()
    slider = studio.page.time._impl.uuid
    frames = [
        b"\x00\x01not msgpack",
        "a text frame",
        msgspec.msgpack.encode({"type": "NoSuchMessage"}),
        msgspec.msgpack.encode(
            {"type": "GuiUpdateMessage", "uuid": slider, "updates": {"value": "soon"}}
        ),
    ]

    def ignored() -> list[str]:
        return [line for line in said if line.startswith("ignored a message from a page")]

    async def send_each() -> None:
        subprotocol = f"viser-v{viser.__version__}"
        for sent, frame in enumerate(frames, 1):
            async with websockets.connect(
                f"ws://127.0.0.1:{studio.address.port}/", subprotocols=[subprotocol]
            ) as connection:
                await connection.send(frame)
                # until the server has said it ignored the frame, or drops the connection (a
                # second of silence was taken for a frame read: most of the test's time)
                deadline = asyncio.get_running_loop().time() + WAIT_S
                with contextlib.suppress(websockets.ConnectionClosed):
                    while len(ignored()) < sent:
                        assert asyncio.get_running_loop().time() < deadline, said
                        with contextlib.suppress(TimeoutError):
                            await asyncio.wait_for(connection.recv(), 0.02)

    try:
        asyncio.run(send_each())
    finally:
        studio.close()
    assert len(ignored()) == len(frames), said
    assert all("\n" not in line for line in ignored())
    assert "Traceback" not in "".join(capfd.readouterr())
    # a traceback logged goes to pytest's log capture here, to the terminal in `choreo studio`
    assert [record.getMessage() for record in caplog.records if record.exc_info] == []
