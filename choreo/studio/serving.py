"""Where the studio's page is served: the address checked before the server starts, so that an
address that does not resolve, is not this computer's, or whose port is taken is one line at
once (viser would try the next thousand ports, and on an address it cannot bind, wait forever).
The studio's ``Front`` is the only server on that address; viser and the timeline listen on
loopback ports the system picks, behind it.

A port named is the one used; only the default (``Address.next_free``) moves on to the next
free port, and port 0 takes any free one. No viser or MuJoCo here: the command line checks the
address before loading them.
"""

from __future__ import annotations

import errno
import logging
import socket
import threading
from collections.abc import Callable

from choreo.errors import ChoreoError
from choreo.studio.address import Address
from choreo.studio.front import Front

RESOLVE_TIMEOUT_S = 1.0  # a host the resolver cannot answer for in this long is refused
NEXT_FREE_TRIES = 100  # the default port moves on at most this far


def port_to_serve(address: Address) -> int:
    """The port the page is served on at ``address``; ``ChoreoError`` (naming ``listen``) if
    the host does not resolve, is not this computer's, or the port named is taken."""
    infos = _resolved(address.host)
    port = address.port
    for _ in range(NEXT_FREE_TRIES if address.next_free else 1):
        problem = _bind_problem(infos, port)
        if problem is None:
            return port
        if problem.errno != errno.EADDRINUSE or not address.next_free:
            raise cannot_serve(Address(address.host, port), problem)
        port += 1
    raise ChoreoError.naming(
        "listen",
        f"{{option}}: ports {address.port}..{port - 1} on {address.host} are all taken; give "
        f"{address.host}:0 for any free one",
    )


def front_at(address: Address) -> Front:
    """The studio's ``Front``, listening at ``address`` (on the next free port if that is
    asked for); ``ChoreoError`` (naming ``listen``) as ``port_to_serve``."""
    port = port_to_serve(address)
    try:
        return Front(address.host, port)
    except OSError as problem:  # taken in the moment since it was checked
        raise cannot_serve(Address(address.host, port), problem) from None


def cannot_serve(address: Address, problem: OSError) -> ChoreoError:
    """The one line (naming ``listen``) for ``address`` that cannot be bound for ``problem``."""
    if problem.errno == errno.EADDRINUSE:
        return ChoreoError.naming(
            "listen",
            f"{{option}} {address.host}:{address.port}: the port is taken (another studio, or "
            f"another server); give another port, or {address.host}:0 for any free one",
        )
    return ChoreoError.naming(
        "listen",
        f"{{option}} {address.host}: cannot serve there: {problem.strerror or problem}; give "
        "an address of this computer, such as 127.0.0.1 (this computer only) or 0.0.0.0 "
        "(every network)",
    )


def _resolved(host: str) -> list[tuple]:
    """``getaddrinfo`` of ``host`` for a server, in at most RESOLVE_TIMEOUT_S (a resolver
    without a network can take half a minute to give up)."""
    found: list[list[tuple]] = []
    failed: list[OSError] = []

    def resolve() -> None:
        try:
            found.append(
                socket.getaddrinfo(host, None, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
            )
        except OSError as error:
            failed.append(error)

    worker = threading.Thread(target=resolve, name="studio-resolve", daemon=True)
    worker.start()
    worker.join(RESOLVE_TIMEOUT_S)
    if found and found[0]:
        return found[0]
    why = "no answer from the resolver" if not failed else "no such host"
    raise ChoreoError.naming(
        "listen",
        f"{{option}} {host}: not an address this computer can serve on ({why}); give an IP "
        "address such as 127.0.0.1 or a host name that resolves",
    )


def _bind_problem(infos: list[tuple], port: int) -> OSError | None:
    """Why ``port`` cannot be bound on one of the addresses ``infos`` (None: it can), bound as
    the server binds (reusing an address still in TIME_WAIT)."""
    for family, kind, proto, _, sockaddr in infos:
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                probe.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            try:
                probe.bind((sockaddr[0], port, *sockaddr[2:]))
            except OSError as error:
                return error
    return None


# The loggers that report, with a traceback, what a page's message did to the server: websockets
# (a frame viser cannot decode ends its connection) and asyncio (a message viser decodes but
# cannot apply fails the task that handled it).
PAGE_MESSAGE_LOGGERS = ("websockets.server", "asyncio")


class UnreadableMessages(logging.Filter):
    """Each error a page's message causes in the server, told as one line to ``say`` instead
    of a traceback (a page, or anything that connects, may send anything)."""

    def __init__(self, say: Callable[[str], None]):
        super().__init__()
        self._say = say

    def filter(self, record: logging.LogRecord) -> bool:
        if record.exc_info is None or record.exc_info[1] is None:
            return True
        error = record.exc_info[1]
        what = f"{type(error).__name__}: {error}".splitlines()[0].rstrip(": ")
        self._say(f"ignored a message from a page that the studio cannot read ({what})")
        return False

    def install(self) -> None:
        for name in PAGE_MESSAGE_LOGGERS:
            logging.getLogger(name).addFilter(self)

    def remove(self) -> None:
        for name in PAGE_MESSAGE_LOGGERS:
            logging.getLogger(name).removeFilter(self)
