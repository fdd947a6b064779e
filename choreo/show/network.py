"""The Zenoh session under a show: the only module that imports ``zenoh`` (``choreo[show]``).

The session's configuration is Zenoh's own: a file (``zenoh_config``, else the ``ZENOH_CONFIG``
environment variable) says the mode (peer, client, router), TLS, user/password authentication,
access control and leases; with none, the session is a peer. With no endpoints, peers find each
other by multicast scouting on the LAN; with ``listen``/``connect`` endpoints
(``tcp/192.168.1.10:7447``, or a router's), only those are used and nothing is scouted, which is
also how tests keep every byte on loopback.

Every key lives under ``choreo/<realm>/``: shows in two realms never hear each other.
"""

from __future__ import annotations

import errno
import ipaddress
import json
import logging
import os
import re
import socket
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from choreo.errors import ChoreoError, OptionError
from choreo.show.names import check_name

try:
    import zenoh
except ImportError:  # pragma: no cover - depends on the installed extras
    zenoh = None  # type: ignore[assignment]

log = logging.getLogger(__name__)
T = TypeVar("T")

ROOT = "choreo"
DEFAULT_REALM = "default"
CONFIG_ENV = "ZENOH_CONFIG"  # Zenoh's own variable for its configuration file

# The Zenoh locators a peer can listen on or connect to: PROTOCOL/HOST:PORT ([v6 address]:PORT)
# for the IP ones, PROTOCOL/PATH for a Unix socket; metadata (?...) and config (#...) may follow.
IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
PATH_PROTOCOLS = ("unixsock-stream",)  # one: the message names it alone
ENDPOINT_EXAMPLE = "tcp/192.168.1.5:7447"
_HOST_PORT = re.compile(r"(?:\[[0-9A-Fa-f:.]+\]|[^\s/:\[\]?#]+):(\d{1,5})")
# Zenoh's messages end with the Rust source line that raised them: not for a user
_RUST_LOCATION = re.compile(r"\s+at /\S+?\.rs:\d+\.?")
# Across a cut link, Zenoh's close waits ~10 s for the peer the network lost, then fails
# (eclipse-zenoh/zenoh#2675); a healthy close takes milliseconds
CLOSE_WAIT_S = 1.0


@dataclass(frozen=True)
class Realm:
    """The keys of one realm."""

    name: str = DEFAULT_REALM

    def performer(self, name: str) -> str:
        """A performer's liveliness token; its queryables are below it (``/clock``,
        ``/stage``)."""
        return f"{ROOT}/{self.name}/performers/{name}"

    def show(self, show_id: str) -> str:
        """The conductor's liveliness token for one run of a show; its heartbeat, stop, progress
        and events are below it."""
        return f"{ROOT}/{self.name}/shows/{show_id}"


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


def _host_port(endpoint: str) -> tuple[str, str, int] | None:
    """(protocol, host, port) of an IP endpoint; None for a Unix socket's."""
    protocol, _, rest = endpoint.partition("/")
    if protocol not in IP_PROTOCOLS:
        return None
    host, _, port = re.split(r"[?#]", rest, maxsplit=1)[0].rpartition(":")
    return protocol, host.strip("[]"), int(port)


def _addresses(protocol: str, host: str, port: int) -> list:
    """``host``'s socket addresses for ``protocol`` (``socket.gaierror`` if it has none)."""
    kind = socket.SOCK_DGRAM if protocol in ("udp", "quic") else socket.SOCK_STREAM
    try:
        return socket.getaddrinfo(host, port, type=kind)
    except UnicodeError:  # a name no DNS label can spell
        raise socket.gaierror(socket.EAI_NONAME, "not a host name") from None


def check_resolves(option: str, endpoint: str) -> None:
    """OptionError naming ``option`` when the endpoint's host has no address: Zenoh would try
    to connect to it again and again, and a show would wait for performers it cannot reach."""
    parts = _host_port(endpoint)
    if parts is None:
        return
    try:
        _addresses(*parts)
    except socket.gaierror:
        raise OptionError(
            option, f"{endpoint!r}: the host {parts[1]!r} does not resolve to an address"
        ) from None


def listen_problem(endpoint: str, config) -> OptionError | None:
    """Why Zenoh cannot listen on ``endpoint``, in choreo's words (Zenoh's are its own): TLS
    with no certificate and key, a host that is not this computer's, a port in use or reserved;
    None when it is none of these."""
    parts = _host_port(endpoint)
    if parts is None:  # a Unix socket's path
        folder = Path(re.split(r"[?#]", endpoint.partition("/")[2], maxsplit=1)[0]).parent
        if not folder.is_dir():
            return OptionError("listen", f"{endpoint!r}: the folder {folder} does not exist")
        return None
    protocol, host, port = parts
    tls = json.loads(config.get_json("transport/link/tls"))
    if protocol in ("tls", "quic") and "#" not in endpoint:
        if not (tls.get("listen_private_key") and tls.get("listen_certificate")):
            return OptionError(
                "listen",
                f"{endpoint!r} needs this computer's TLS certificate and private key: name them "
                "in the Zenoh configuration given with {zenoh_config} (transport/link/tls: "
                "listen_certificate and listen_private_key), as docs/shows.md shows",
                mentions=("zenoh_config",),
            )
    every = f"{protocol}/0.0.0.0:{port}"
    try:
        family, kind, _, _, address = _addresses(protocol, host, port)[0]
    except socket.gaierror:
        return OptionError(
            "listen",
            f"{endpoint!r}: the host {host!r} does not resolve; give an address of "
            f"this computer, or {every} for all of them",
        )
    with socket.socket(family, kind) as probe:
        try:
            probe.bind(address)
        except OSError as error:
            return _bind_problem(endpoint, error.errno, host, port, every)
    return None


def _bind_problem(endpoint: str, code: int | None, host: str, port: int, every: str):
    if code == errno.EADDRNOTAVAIL:
        why = f"{host} is not an address of this computer; give one of its own, or {every}"
    elif code == errno.EADDRINUSE:
        why = f"port {port} is in use there (another performer or program); choose another port"
    elif code == errno.EACCES:
        why = f"port {port} needs administrator rights (below 1024); choose one from 1024 up"
    else:
        return None
    return OptionError("listen", f"{endpoint!r}: {why}")


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

    def __init__(
        self,
        listen: Sequence[str] = (),
        connect: Sequence[str] = (),
        *,
        zenoh_config: str | Path | None = None,
        realm: str = DEFAULT_REALM,
    ):
        for option, endpoints in (("listen", listen), ("connect", connect)):
            for endpoint in endpoints:
                check_endpoint(option, endpoint)
        self.realm = Realm(check_name("realm", realm))
        if zenoh is None:
            raise ChoreoError(
                "shows need Zenoh: install the show extra, pip install 'choreo[show]'"
            )
        config = _config(zenoh_config)
        try:
            if json.loads(config.get_json("mode")) is None:
                config.insert_json5("mode", '"peer"')
            if listen or connect:  # only the endpoints named: no scouting, no other interface
                config.insert_json5("scouting/multicast/enabled", "false")
                config.insert_json5("scouting/gossip/enabled", "false")
                config.insert_json5("listen/endpoints", json.dumps(list(listen)))
                config.insert_json5("connect/endpoints", json.dumps(list(connect)))
            self.exposure = exposure(config)
            for endpoint in connect:
                check_resolves("connect", endpoint)
            self._session = zenoh.open(config)
        except zenoh.ZError as error:
            for endpoint in listen:  # the cause in choreo's words, where it can tell it
                problem = listen_problem(endpoint, config)
                if problem is not None:
                    raise problem from None
            raise ChoreoError(f"cannot open the Zenoh session: {_reason(error)}") from None
        self._keep: list = []  # declared entities live as long as they are referenced

    def close(self) -> None:
        """Close the session, waiting at most ``CLOSE_WAIT_S``. A performer that lost its
        conductor to a cut cable has stopped its servos long before; making its Ctrl-C wait 10 s
        more for Zenoh to give up on the lost peer helps no one. The rest of the close goes on
        in a daemon thread, which ends with the process at the latest."""
        self._keep.clear()
        closer = threading.Thread(
            target=_close_quietly, args=(self._session,), name="zenoh-close", daemon=True
        )
        closer.start()
        closer.join(CLOSE_WAIT_S)

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

    def ask_each(self, key: str, timeout_s: float) -> list[bytes]:
        """Every reply to one query on ``key``, from every queryable there (two performers that
        took one name both answer)."""

        def replies() -> list[bytes]:
            got = self._session.get(
                key,
                timeout=timeout_s,
                target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.ConsolidationMode.NONE,
            )
            return [reply.ok.payload.to_bytes() for reply in got if reply.ok is not None]

        return _interruptible(replies)

    def ask_all(self, requests: dict[str, bytes], timeout_s: float) -> dict[str, bytes | None]:
        """One query per key at once; each key's first reply (None: none in time)."""
        return _interruptible(lambda: self._ask_all(requests, timeout_s))

    def _ask_all(self, requests: dict[str, bytes], timeout_s: float) -> dict[str, bytes | None]:
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

        def keys() -> list[str]:
            replies = self._session.liveliness().get(key, timeout=timeout_s)
            return [str(reply.ok.key_expr) for reply in replies if reply.ok is not None]

        return _interruptible(keys)


def _interruptible(call: Callable[[], T]) -> T:
    """``call()`` in a thread of its own while this one waits in Python. A Ctrl-C that arrives
    while Zenoh waits for replies is lost inside it (the benchmark's Ctrl-C was, mid-show);
    here it reaches the caller. (Clock round trips call Zenoh directly: a thread would lengthen
    one leg only.)"""
    result: list[T] = []
    failure: list[BaseException] = []

    def run() -> None:
        try:
            result.append(call())
        except BaseException as error:  # handed to the caller, whatever it is
            failure.append(error)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.05)
    if failure:
        raise failure[0]
    return result[0]


def _close_quietly(session: zenoh.Session) -> None:
    """Zenoh's close; its failure to reach a lost peer has no one left to tell."""
    try:
        session.close()
    except zenoh.ZError as error:
        log.debug("Zenoh's close failed: %s", _reason(error))


def _reason(error: Exception) -> str:
    """Zenoh's message without the Rust source line it ends with."""
    text = _RUST_LOCATION.sub("", str(error))
    found = re.search(r'msg: "([^"]*)"', text)  # a JSON5 error: the message inside
    if found:
        return found[1]
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    # a parser's picture of the line (" --> 1:1", " | ...") is dropped; its "= why" is kept
    notes = [line.removeprefix("= ") for line in lines[1:] if line.startswith("= ")]
    return " ".join(lines[:1] + notes)


def _config(path: str | Path | None):
    """The configuration from ``path``, else from ``$ZENOH_CONFIG``, else Zenoh's defaults."""
    source = str(path) if path is not None else os.environ.get(CONFIG_ENV)
    if not source:
        return zenoh.Config()
    try:
        return zenoh.Config.from_file(source)
    except zenoh.ZError as error:
        where = "" if path is not None else f" (from {CONFIG_ENV})"
        raise OptionError(
            "zenoh_config",
            f"{source}{where} is not a Zenoh configuration file that can be used: {_reason(error)}",
        ) from None


def exposure(config) -> str | None:
    """A warning when this session can be reached from beyond this computer with no
    authentication; None otherwise. Authenticated: user/password checked against a dictionary
    file, mutual TLS on every link, or a client whose router checks its user/password."""

    def setting(key: str):
        return json.loads(config.get_json(key))

    mode = setting("mode") or "peer"
    listen = setting("listen/endpoints")
    if isinstance(listen, dict):  # per mode
        listen = listen.get(mode, [])
    endpoints = [*(listen if mode != "client" else []), *setting("connect/endpoints")]
    scouting = setting("scouting/multicast/enabled")
    if not endpoints and mode != "client":
        endpoints = ["tcp/[::]:0"]  # Zenoh's default: every interface
    if scouting is not False or not all(_loopback(e) for e in endpoints):
        usrpwd = setting("transport/auth/usrpwd")
        if usrpwd["dictionary_file"] or (mode == "client" and usrpwd["user"]):
            return None
        mutual = setting("transport/link/tls/enable_mtls")
        if mutual and all(e.split("/", 1)[0] in ("tls", "quic") for e in endpoints):
            return None
        return (
            "this session is reachable beyond this computer with no Zenoh authentication: "
            "anyone on the network can join the show; see docs/shows.md (TLS, user/password, "
            "access control)"
        )
    return None


def _loopback(endpoint: str) -> bool:
    protocol, _, rest = endpoint.partition("/")
    if protocol in PATH_PROTOCOLS:
        return True
    host = re.split(r"[?#]", rest, maxsplit=1)[0].rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
