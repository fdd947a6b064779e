"""The Zenoh session under a show: the only module that imports ``zenoh`` (``choreo[show]``).

Peer to peer: with no endpoints, peers find each other by multicast scouting on the LAN; with
``listen``/``connect`` endpoints (``tcp/192.168.1.10:7447``, or a router's), only those are used
and nothing is scouted, which is also how tests keep every byte on loopback.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Callable, Sequence

from choreo.errors import ChoreoError, OptionError

try:
    import zenoh
except ImportError:  # pragma: no cover - depends on the installed extras
    zenoh = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

ROOT = "choreo"

# The Zenoh locators a peer can listen on or connect to: PROTOCOL/HOST:PORT ([v6 address]:PORT)
# for the IP ones, PROTOCOL/PATH for a Unix socket; metadata (?...) and config (#...) may follow.
IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
PATH_PROTOCOLS = ("unixsock-stream",)  # one: the message names it alone
ENDPOINT_EXAMPLE = "tcp/192.168.1.5:7447"
_HOST_PORT = re.compile(r"(?:\[[0-9A-Fa-f:.]+\]|[^\s/:\[\]?#]+):(\d{1,5})")
# Zenoh's messages end with the Rust source line that raised them: not for a user
_RUST_LOCATION = re.compile(r"\s+at /\S+?\.rs:\d+\.?")


def performer_key(name: str) -> str:
    """The performer's liveliness token; its queryables are below it (``/clock``, ``/stage``)."""
    return f"{ROOT}/performers/{name}"


def show_key(show_id: str) -> str:
    """The conductor's liveliness token for one run of a show; stop and events are below it."""
    return f"{ROOT}/shows/{show_id}"


def name_of(key: str) -> str:
    """The last chunk of a key: a performer's name."""
    return key.rsplit("/", 1)[-1]


def check_endpoint(option: str, endpoint: str) -> None:
    """OptionError naming ``option`` unless ``endpoint`` has the form of a Zenoh endpoint (whether
    anything answers there is for the session to find)."""
    protocol, _, rest = endpoint.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if protocol in PATH_PROTOCOLS and address:
        return
    port = _HOST_PORT.fullmatch(address)
    if protocol in IP_PROTOCOLS and port and int(port[1]) <= 65535:
        return
    raise OptionError(
        option,
        f"{endpoint!r} is not a Zenoh endpoint: write PROTOCOL/HOST:PORT (PROTOCOL one of "
        f"{', '.join(IP_PROTOCOLS)}; PORT 0-65535) or {PATH_PROTOCOLS[0]}/PATH, e.g. "
        f"{ENDPOINT_EXAMPLE}",
    )


class Request:
    """A query to answer, now or later from another thread (exactly once)."""

    def __init__(self, query):
        self._query = query
        self.payload: bytes = query.payload.to_bytes() if query.payload is not None else b""

    def reply(self, payload: bytes) -> None:
        try:
            self._query.reply(self._query.key_expr, payload)
        finally:
            self._query.drop()  # the asker's get ends here, not at its time-out


class Network:
    """One Zenoh session; closing it withdraws every token, queryable and subscriber."""

    def __init__(self, listen: Sequence[str] = (), connect: Sequence[str] = ()):
        for option, endpoints in (("listen", listen), ("connect", connect)):
            for endpoint in endpoints:
                check_endpoint(option, endpoint)
        if zenoh is None:
            raise ChoreoError(
                "shows need Zenoh: install the show extra, pip install 'choreo[show]'"
            )
        try:
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            if listen or connect:  # only the endpoints named: no scouting, no other interface
                config.insert_json5("scouting/multicast/enabled", "false")
                config.insert_json5("scouting/gossip/enabled", "false")
                config.insert_json5("listen/endpoints", json.dumps(list(listen)))
                config.insert_json5("connect/endpoints", json.dumps(list(connect)))
            self._session = zenoh.open(config)
        except zenoh.ZError as error:
            reason = _RUST_LOCATION.sub("", str(error))
            raise ChoreoError(f"cannot open the Zenoh session: {reason}") from None
        self._keep: list = []  # declared entities live as long as they are referenced

    def close(self) -> None:
        self._keep.clear()
        self._session.close()

    def __enter__(self) -> Network:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def announce(self, key: str) -> None:
        """Hold a liveliness token at ``key`` until the session closes (or the process dies)."""
        self._keep.append(self._session.liveliness().declare_token(key))

    def serve(self, key: str, on_request: Callable[[Request], None]) -> None:
        """Call ``on_request`` (in Zenoh's thread: return quickly) for each query on ``key``."""
        self._keep.append(
            self._session.declare_queryable(key, lambda query: on_request(Request(query)))
        )

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 5.0) -> bytes | None:
        """The first reply to one query on ``key``; None when none came in ``timeout_s``."""
        for reply in self._session.get(key, payload=payload, timeout=timeout_s):
            if reply.ok is not None:
                return reply.ok.payload.to_bytes()
            log.info("error reply on %s: %s", key, reply.err)
        return None

    def ask_all(self, requests: dict[str, bytes], timeout_s: float) -> dict[str, bytes | None]:
        """One query per key at once; each key's first reply (None: none in time)."""
        pending = {
            key: self._session.get(key, payload=payload, timeout=timeout_s)
            for key, payload in requests.items()
        }
        answers: dict[str, bytes | None] = {}
        for key, replies in pending.items():
            answers[key] = None
            for reply in replies:
                if reply.ok is not None and answers[key] is None:
                    answers[key] = reply.ok.payload.to_bytes()
        return answers

    def publish(self, key: str, payload: bytes) -> None:
        self._session.put(key, payload, express=True)

    def subscribe(self, key: str, on_sample: Callable[[str, bytes], None]) -> Callable[[], None]:
        """``on_sample(key, payload)`` for each publication on ``key``; returns the cancel."""
        return self._declared(
            self._session.declare_subscriber(
                key, lambda sample: on_sample(str(sample.key_expr), sample.payload.to_bytes())
            )
        )

    def watch(self, key: str, on_change: Callable[[str, bool], None]) -> Callable[[], None]:
        """``on_change(key, alive)`` as liveliness tokens matching ``key`` appear and vanish
        (those already there first); returns the cancel."""
        return self._declared(
            self._session.liveliness().declare_subscriber(
                key,
                lambda sample: on_change(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT),
                history=True,
            )
        )

    def _declared(self, entity) -> Callable[[], None]:
        self._keep.append(entity)

        def cancel() -> None:
            if entity in self._keep:
                self._keep.remove(entity)
                entity.undeclare()

        return cancel

    def alive(self, key: str, timeout_s: float = 1.0) -> list[str]:
        """The keys of the liveliness tokens matching ``key`` now."""
        replies = self._session.liveliness().get(key, timeout=timeout_s)
        return [str(reply.ok.key_expr) for reply in replies if reply.ok is not None]
