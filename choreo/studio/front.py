"""The studio's one address: the browser asks everything of the ``--listen`` address, and the
front passes each connection on to the server that answers it, both on loopback ports the system
picks. viser serves its page and its websocket at the root of a server of its own, with no hook
for other routes; the timeline's page (``timeline_server``) needs POST and a stream of events,
which viser's websockets library refuses.

The front reads a connection's request head only, picks the server by the path's prefix, and
then pipes the bytes both ways unchanged (a websocket upgrade included). A connection so carries
one server's requests only: both close a connection after each plain HTTP answer (viser's
websockets library always does; the timeline's says ``Connection: close``), so the browser's
next request comes on a new connection and is routed afresh.

Nothing a client sends or does (a malformed head, a socket closed mid-stream) raises or logs
more than a debug line: the studio's terminal is the user's.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections.abc import Coroutine, Mapping
from typing import Any

log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"
MAX_HEAD_BYTES = 65_536  # a request head longer than this is refused
HEAD_TIMEOUT_S = 60.0  # a connection that sends no whole head in this long is closed
CHUNK_BYTES = 65_536
CLOSE_TIMEOUT_S = 2.0
_REFUSAL = b"not an HTTP request\n"
BAD_REQUEST = (
    b"HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\nConnection: close\r\n"
    b"Content-Length: %d\r\n\r\n%s" % (len(_REFUSAL), _REFUSAL)
)


def route(head: bytes, routes: Mapping[str, int], default_port: int) -> int | None:
    """The port that answers the request whose head is ``head``: that of the first prefix in
    ``routes`` its path starts with, else ``default_port``; None if it is not an HTTP/1
    request (``METHOD /path HTTP/1.x``)."""
    words = head.partition(b"\r\n")[0].split(b" ")
    if len(words) != 3:
        return None
    method, target, version = words
    if not (method.isalpha() and target.startswith(b"/") and version.startswith(b"HTTP/1.")):
        return None
    path = target.partition(b"?")[0].decode("latin-1")
    return next((port for prefix, port in routes.items() if path.startswith(prefix)), default_port)


class Front:
    """Listens on ``host``:``port`` (0: a free one) from construction, so that an address that
    cannot be served raises ``OSError`` at once; ``start`` then passes each connection on to
    the loopback port ``route`` picks. ``close`` ends every connection."""

    def __init__(self, host: str, port: int):
        self._loop = asyncio.new_event_loop()
        self._loop.set_exception_handler(_quietly)
        self._thread = threading.Thread(
            target=self._loop.run_forever, name="studio-front", daemon=True
        )
        self._thread.start()
        self._connections: set[asyncio.Task] = set()
        self._routes: dict[str, int] = {}
        self._default_port = 0
        try:
            self._server = self._call(
                asyncio.start_server(
                    self._serve, host, port, limit=MAX_HEAD_BYTES, start_serving=False
                )
            )
        except BaseException:
            self._stop_loop()
            raise
        self.port = int(self._server.sockets[0].getsockname()[1])

    def start(self, default_port: int, routes: Mapping[str, int]) -> None:
        """Serve: a request whose path starts with a prefix in ``routes`` goes to its port,
        everything else to ``default_port``."""
        self._default_port, self._routes = default_port, dict(routes)
        self._call(self._server.start_serving())

    def close(self) -> None:
        if not self._thread.is_alive():
            return
        with contextlib.suppress(Exception):
            self._call(self._shut(), CLOSE_TIMEOUT_S)
        self._stop_loop()

    def _call(self, coroutine: Coroutine[Any, Any, Any], timeout_s: float | None = None) -> Any:
        return asyncio.run_coroutine_threadsafe(coroutine, self._loop).result(timeout_s)

    async def _shut(self) -> None:
        self._server.close()
        for connection in self._connections:
            connection.cancel()
        await asyncio.gather(*self._connections, return_exceptions=True)
        await asyncio.sleep(0)  # the closed sockets' last callbacks

    def _stop_loop(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(CLOSE_TIMEOUT_S)
        if not self._thread.is_alive():
            self._loop.close()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._connections.add(task)
        backend: asyncio.StreamWriter | None = None
        try:
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT_S)
            port = route(head, self._routes, self._default_port)
            if port is None:
                await _refuse(writer)
                return
            backend_reader, backend = await asyncio.open_connection(LOOPBACK, port)
            backend.write(head)  # what the client sent after its head is still in ``reader``
            await _splice(reader, writer, backend_reader, backend)
        except asyncio.LimitOverrunError:  # a head longer than any request's
            await _refuse(writer)
        except (OSError, EOFError, TimeoutError) as error:  # a client gone, or never asking
            log.debug("front: a connection ended: %r", error)
        finally:
            self._connections.discard(task)
            for end in (writer, backend):
                if end is not None:
                    end.close()


async def _refuse(writer: asyncio.StreamWriter) -> None:
    log.debug("front: refused a connection that sent no HTTP request")
    with contextlib.suppress(OSError):
        writer.write(BAD_REQUEST)
        await writer.drain()


async def _splice(
    client_reader: asyncio.StreamReader,
    client: asyncio.StreamWriter,
    backend_reader: asyncio.StreamReader,
    backend: asyncio.StreamWriter,
) -> None:
    """Both ways until the backend is done (it answered and closed, or the websocket ended) or
    either side fails; a client that only stopped sending still gets its answer."""
    upstream = asyncio.ensure_future(_pipe(client_reader, backend))
    downstream = asyncio.ensure_future(_pipe(backend_reader, client))
    try:
        done, _ = await asyncio.wait({upstream, downstream}, return_when=asyncio.FIRST_COMPLETED)
        if downstream not in done and upstream.exception() is None:
            await downstream
    finally:
        for pipe in (upstream, downstream):
            pipe.cancel()
        results = await asyncio.gather(upstream, downstream, return_exceptions=True)
        log.debug("front: pipes ended: %r", results)


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    while chunk := await reader.read(CHUNK_BYTES):
        writer.write(chunk)
        await writer.drain()
    if writer.can_write_eof():
        writer.write_eof()


def _quietly(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
    """What asyncio would print with a traceback (a socket that failed under a callback): a
    debug line; the clients are anybody's."""
    log.debug("front: %s (%r)", context.get("message"), context.get("exception"))
