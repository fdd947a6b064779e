"""The studio's one address: each connection goes by its request's path to the server behind
that answers it, its bytes piped both ways unchanged (a websocket's too), and nothing a client
does (a malformed request, a socket closed mid-stream) raises or prints."""

from __future__ import annotations

import contextlib
import errno
import logging
import socket
import struct
import threading
from collections.abc import Callable, Iterator

import pytest

from choreo.studio.front import BAD_REQUEST, Front, route

WAIT_S = 5.0
ROUTES = {"/timeline/": 2000}


class FakeBackend:
    """A loopback server whose every connection ``handle`` serves (in a thread of its own);
    ``heads`` are the request heads it read, ``ended`` is set when a connection's peer went."""

    def __init__(self, handle: Callable[[socket.socket, FakeBackend], None]):
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self.heads: list[bytes] = []
        self.ended = threading.Event()
        self._handle = handle
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                connection, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(connection,), daemon=True).start()

    def _serve(self, connection: socket.socket) -> None:
        with connection:
            connection.settimeout(WAIT_S)
            head = b""
            while b"\r\n\r\n" not in head:
                byte = connection.recv(1)
                if not byte:
                    return
                head += byte
            self.heads.append(head)
            try:
                self._handle(connection, self)
            except OSError:
                self.ended.set()

    def close(self) -> None:
        with contextlib.suppress(OSError):  # wakes the accept under way (close alone does not)
            self._listener.shutdown(socket.SHUT_RDWR)
        self._listener.close()


def answer(text: bytes) -> Callable[[socket.socket, FakeBackend], None]:
    """A backend that answers ``text`` to one request, and closes."""

    def handle(connection: socket.socket, _backend: FakeBackend) -> None:
        connection.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: %d\r\n\r\n%s" % (len(text), text))

    return handle


def echo_upper(connection: socket.socket, backend: FakeBackend) -> None:
    """A websocket-like backend: switches protocols, then sends back each message in upper
    case until its peer goes."""
    connection.sendall(b"HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\n\r\n")
    while message := connection.recv(4096):
        connection.sendall(message.upper())
    backend.ended.set()


def stream_forever(connection: socket.socket, backend: FakeBackend) -> None:
    """An event stream that never ends: a line every few milliseconds until its peer goes."""
    connection.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n\r\n")
    while not backend.ended.wait(0.005):
        connection.sendall(b"data: tick\n\n")  # OSError once the peer is gone


@pytest.fixture
def front() -> Iterator[Front]:
    front = Front("127.0.0.1", 0)
    yield front
    front.close()


@pytest.fixture
def quiet(caplog, capfd) -> Iterator[None]:
    """Nothing the front does is told above debug level, nor printed."""
    caplog.set_level(logging.DEBUG)
    yield
    loud = [r for r in caplog.records if r.levelno > logging.DEBUG]
    assert loud == [], [r.getMessage() for r in loud]
    assert "Traceback" not in "".join(capfd.readouterr())


def connect(front: Front) -> socket.socket:
    return socket.create_connection(("127.0.0.1", front.port), timeout=WAIT_S)


def read_all(client: socket.socket) -> bytes:
    received = b""
    while chunk := client.recv(4096):
        received += chunk
    return received


def test_a_request_goes_by_its_path_prefix_and_everything_else_to_the_default():
    assert route(b"GET /timeline/ HTTP/1.1\r\nHost: x\r\n\r\n", ROUTES, 1000) == 2000
    assert route(b"POST /timeline/command?v=2 HTTP/1.1\r\n\r\n", ROUTES, 1000) == 2000
    assert route(b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\n", ROUTES, 1000) == 1000
    assert route(b"GET /timeline HTTP/1.1\r\n\r\n", ROUTES, 1000) == 1000  # not under it
    assert route(b"GET /?/timeline/ HTTP/1.0\r\n\r\n", ROUTES, 1000) == 1000  # the query
    for malformed in (
        b"hello there\r\n\r\n",
        b"GET /timeline/ HTTP/2\r\n\r\n",
        b"GET timeline/ HTTP/1.1\r\n\r\n",
        b"GET  / HTTP/1.1\r\n\r\n",
        b"G\x00T / HTTP/1.1\r\n\r\n",
        b"\r\n\r\n",
    ):
        assert route(malformed, ROUTES, 1000) is None, malformed


def test_each_connection_reaches_the_server_its_path_names_with_its_bytes_unchanged(front, quiet):
    viser, timeline = FakeBackend(answer(b"viser")), FakeBackend(answer(b"timeline"))
    front.start(viser.port, {"/timeline/": timeline.port})
    try:
        headers = b"Host: studio\r\nX-Odd: \xe9\r\n\r\n"  # not even ASCII
        for path, expected in ((b"/", b"viser"), (b"/timeline/events", b"timeline")):
            with connect(front) as client:
                client.sendall(b"GET %s HTTP/1.1\r\n%s" % (path, headers))
                assert read_all(client).endswith(b"\r\n\r\n" + expected)
        assert viser.heads == [b"GET / HTTP/1.1\r\n" + headers]
        assert timeline.heads == [b"GET /timeline/events HTTP/1.1\r\n" + headers]
    finally:
        viser.close()
        timeline.close()


def test_a_websocket_is_piped_both_ways_until_the_client_closes(front, quiet):
    backend = FakeBackend(echo_upper)
    front.start(backend.port, ROUTES)
    try:
        with connect(front) as client:
            # the first message in the same packet as the head: it follows the head through
            client.sendall(b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\nhello")
            received = b""
            while not received.endswith(b"HELLO"):
                received += client.recv(4096)
            assert received.startswith(b"HTTP/1.1 101 ")
            for message in (b"one", b"\x00\xff binary \x81", b"x" * 200_000):
                client.sendall(message)
                back = b""
                while len(back) < len(message):
                    back += client.recv(65536)
                assert back == message.upper()
        assert backend.ended.wait(WAIT_S)  # the client's close reached the backend
    finally:
        backend.close()


def test_a_client_that_drops_its_socket_mid_stream_ends_the_backends_quietly(front, quiet):
    backend = FakeBackend(stream_forever)
    front.start(backend.port, ROUTES)
    try:
        client = connect(front)
        client.sendall(b"GET /events HTTP/1.1\r\n\r\n")
        assert client.recv(4096).startswith(b"HTTP/1.1 200 OK")
        client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        client.close()  # a reset, not a goodbye
        assert backend.ended.wait(WAIT_S)
    finally:
        backend.close()


def test_a_malformed_request_gets_a_400_and_nothing_is_passed_on(front, quiet):
    backend = FakeBackend(answer(b"never"))
    front.start(backend.port, ROUTES)
    try:
        for malformed in (b"hello there\r\n\r\n", b"\x16\x03\x01\x02\x00\r\n\r\n"):
            with connect(front) as client:
                client.sendall(malformed)
                assert read_all(client) == BAD_REQUEST
        with connect(front) as client:  # a head longer than any request's
            client.sendall(b"GET /" + b"a" * 100_000)
            try:
                assert read_all(client) == BAD_REQUEST
            except ConnectionResetError:
                pass  # the front closed with the rest unread: the system may reset instead
        with connect(front) as client:  # a client gone before its head was whole
            client.sendall(b"GET / HT")
        assert backend.heads == []
    finally:
        backend.close()


def test_a_client_that_only_stopped_sending_still_gets_its_answer(front, quiet):
    def answer_after_eof(connection: socket.socket, backend: FakeBackend) -> None:
        body = connection.recv(4096)
        while more := connection.recv(4096):  # until the client's end of sending arrives
            body += more
        answer(body.upper())(connection, backend)

    backend = FakeBackend(answer_after_eof)
    front.start(backend.port, ROUTES)
    try:
        with connect(front) as client:
            client.sendall(b"POST /command HTTP/1.0\r\n\r\nbody")
            client.shutdown(socket.SHUT_WR)
            assert read_all(client).endswith(b"\r\n\r\nBODY")
    finally:
        backend.close()


def test_a_server_behind_that_is_gone_closes_the_connection_quietly(front, quiet):
    gone = FakeBackend(answer(b"never"))
    gone.close()
    front.start(gone.port, ROUTES)
    with connect(front) as client:
        client.sendall(b"GET / HTTP/1.1\r\n\r\n")
        assert read_all(client) == b""


def test_close_ends_every_connection_and_frees_the_address(quiet):
    front = Front("127.0.0.1", 0)
    backend = FakeBackend(echo_upper)
    front.start(backend.port, ROUTES)
    try:
        with connect(front) as client:
            client.sendall(b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\n")
            assert client.recv(4096).startswith(b"HTTP/1.1 101 ")
            front.close()
            assert read_all(client) == b""  # the front closed it
        assert backend.ended.wait(WAIT_S)
        with pytest.raises(ConnectionRefusedError):
            connect(front)
        front.close()  # twice is once
        assert not any(thread.name == "studio-front" for thread in threading.enumerate())
    finally:
        backend.close()


def test_an_address_that_cannot_be_bound_is_an_os_error_at_once():
    with socket.create_server(("127.0.0.1", 0)) as other:
        with pytest.raises(OSError) as taken:
            Front("127.0.0.1", other.getsockname()[1])
    assert taken.value.errno == errno.EADDRINUSE
    assert not any(thread.name == "studio-front" for thread in threading.enumerate())
