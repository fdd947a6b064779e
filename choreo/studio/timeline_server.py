"""The timeline's page component served beside viser's page: its files (``web/``: HTML, a
canvas and a script; no build step, nothing fetched from elsewhere), the song, the state as
Server-Sent Events (``state``, ``play``, ``time``, ``status``), and the page's requests taken as
posted JSON, all under ``ROOT``, on a loopback port the system picks: the studio's ``front``
passes it the requests under ``ROOT`` on the studio's one address. ``frame_html`` frames it
into viser's page, full width at the bottom.

viser's GUI lays controls out in a side panel; lanes of keyframe diamonds, a waveform and curves
under one playhead need a canvas.
"""

from __future__ import annotations

import json
import logging
import queue
import threading
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from typing import Any

from choreo.studio.front import LOOPBACK
from choreo.studio.timeline_requests import Request, RequestError, parse_request

log = logging.getLogger(__name__)

MAX_REQUEST_BYTES = 1_000_000
KEEP_ALIVE_S = 15.0
# how often the server's loop looks whether it is to stop: closing the studio waits for that
# look (http.server's default, 0.5 s, was a quarter of a second of every close on average)
SHUTDOWN_POLL_S = 0.05
ROOT = "/timeline/"  # every path served, on the studio's address; viser's are all others
FILES = {  # what the component's server serves from web/: path -> (file, content type)
    ROOT: ("timeline.html", "text/html; charset=utf-8"),
    f"{ROOT}timeline.js": ("timeline.js", "text/javascript; charset=utf-8"),
    f"{ROOT}timeline.css": ("timeline.css", "text/css; charset=utf-8"),
}
SONG_TYPES = {".ogg": "audio/ogg", ".mp3": "audio/mpeg", ".wav": "audio/wav", ".flac": "audio/flac"}


class Broadcast:
    """The newest event of each kind, numbered; every open page waits here for newer ones."""

    def __init__(self) -> None:
        self._changed = threading.Condition()
        self._latest: dict[str, tuple[int, str]] = {}  # kind -> (number, JSON)
        self._count = 0
        self.closed = False

    def publish(self, kind: str, data: Any) -> None:
        text = json.dumps(data, separators=(",", ":"))
        with self._changed:
            self._count += 1
            self._latest[kind] = (self._count, text)
            self._changed.notify_all()

    def newer(self, seen: int, timeout_s: float) -> tuple[int, list[tuple[str, str]]]:
        """The events numbered after ``seen`` in order (waiting up to ``timeout_s`` for one)."""
        with self._changed:
            self._changed.wait_for(lambda: self._count > seen or self.closed, timeout_s)
            fresh = sorted(
                (number, kind, text)
                for kind, (number, text) in self._latest.items()
                if number > seen
            )
            return self._count, [(kind, text) for _, kind, text in fresh]

    def close(self) -> None:
        with self._changed:
            self.closed = True
            self._changed.notify_all()


class TimelineServer:
    """Serves the timeline's page on a free loopback port; ``on_request`` hears its requests
    (from the server's threads), ``song`` names the song file to serve."""

    def __init__(self, on_request: Callable[[Request], None], song: Callable[[], Path | None]):
        self.events = Broadcast()
        self._on_request = on_request
        self._song = song
        handler = type("Handler", (_Handler,), {"timeline": self})
        self._http = ThreadingHTTPServer((LOOPBACK, 0), handler)
        self._http.daemon_threads = True
        self.port = int(self._http.server_address[1])
        self._thread = threading.Thread(
            target=self._http.serve_forever,
            args=(SHUTDOWN_POLL_S,),
            name="studio-timeline",
            daemon=True,
        )
        # the page's requests are handled one at a time in the order they came (an edit
        # reloads and simulates: seconds, while the page goes on asking)
        self._requests: queue.Queue[Request | None] = queue.Queue()
        self._worker = threading.Thread(
            target=self._handle_requests, name="studio-timeline-requests", daemon=True
        )

    def start(self) -> None:
        self._thread.start()
        self._worker.start()

    def close(self) -> None:
        self.events.close()
        self._requests.put(None)
        if self._thread.is_alive():
            self._http.shutdown()
        self._http.server_close()
        if self._worker.is_alive():
            self._worker.join(timeout=2.0)

    def take(self, request: Request) -> None:
        self._requests.put(request)

    def _handle_requests(self) -> None:
        while True:
            request = self._requests.get()
            if request is None:
                return
            if request.op == "scrub" and self._newer_scrub_waits():
                continue  # a drag: only where it went on to matters
            try:
                self._on_request(request)
            except Exception:  # noqa: BLE001  a bug must not stop the page being heard
                log.exception("the timeline's %s request failed", request.op)

    def _newer_scrub_waits(self) -> bool:
        with self._requests.mutex:
            waiting = self._requests.queue
            return bool(waiting) and waiting[0] is not None and waiting[0].op == "scrub"

    def publish(self, kind: str, data: Any) -> None:
        self.events.publish(kind, data)


class _Handler(BaseHTTPRequestHandler):
    timeline: TimelineServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002  (the base's name)
        log.debug("timeline: " + format, *args)

    def do_GET(self) -> None:  # noqa: N802  (http.server's name)
        path = self.path.partition("?")[0]
        if path in FILES:
            name, kind = FILES[path]
            body = resources.files(__package__).joinpath("web", name).read_bytes()
            self._send(HTTPStatus.OK, kind, body)
        elif path == f"{ROOT}events":
            self._stream_events()
        elif path == f"{ROOT}song":
            self._send_song()
        else:
            self._send(HTTPStatus.NOT_FOUND, "text/plain", b"not found")

    def do_POST(self) -> None:  # noqa: N802
        if self.path != f"{ROOT}command":
            self._send(HTTPStatus.NOT_FOUND, "text/plain", b"not found")
            return
        length = int(self.headers.get("Content-Length") or 0)
        if not 0 < length <= MAX_REQUEST_BYTES:
            self._send(HTTPStatus.BAD_REQUEST, "text/plain", b"a request needs a JSON body")
            return
        try:
            request = parse_request(self.rfile.read(length))
        except RequestError as error:
            log.warning("the timeline's page sent %s", error)
            self._send(HTTPStatus.BAD_REQUEST, "text/plain", str(error).encode())
            return
        self.timeline.take(request)
        self._send(HTTPStatus.NO_CONTENT, "text/plain", b"")

    def _send(self, status: HTTPStatus, kind: str, body: bytes) -> None:
        self.send_response(status)
        self._send_closing()
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _send_song(self) -> None:
        song = self.timeline._song()
        kind = SONG_TYPES.get(song.suffix.lower()) if song is not None else None
        try:
            body = song.read_bytes() if song is not None and kind else None
        except OSError:
            body = None
        if body is None or kind is None:
            self._send(HTTPStatus.NOT_FOUND, "text/plain", b"no song")
            return
        self._send(HTTPStatus.OK, kind, body)

    def _send_closing(self) -> None:
        """One request a connection: the studio's ``front`` routes a connection by its first
        request, and the browser's next one may be viser's."""
        self.send_header("Connection", "close")

    def _stream_events(self) -> None:
        self.send_response(HTTPStatus.OK)
        self._send_closing()
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        events, seen = self.timeline.events, 0
        try:
            while not events.closed:
                seen, fresh = events.newer(seen, KEEP_ALIVE_S)
                chunk = "".join(f"event: {kind}\ndata: {text}\n\n" for kind, text in fresh)
                self.wfile.write((chunk or ": still here\n\n").encode())
                self.wfile.flush()
        except OSError:  # the tab went away
            return


# --- the frame in viser's page ------------------------------------------------------------------

TIMELINE_HEIGHT = "42vh"

# Runs once in viser's page (an image that fails to load: viser puts HTML in with innerHTML,
# where a <script> would not run): the timeline's frame goes full width at the bottom and viser's
# page above it; keys pressed outside the frame are passed to it; the tab says choreo.
_FRAME_SCRIPT = """
(function () {
  if (document.getElementById("choreo-timeline")) return;
  const frame = document.createElement("iframe");
  frame.id = "choreo-timeline";
  frame.title = "timeline";
  frame.src = %(root)s;
  frame.style.cssText = "position:fixed;left:0;right:0;bottom:0;width:100%%;height:%(height)s;" +
    "border:0;z-index:150;background:#fbfbfc";
  document.body.appendChild(frame);
  const root = document.getElementById("root") || document.body.firstElementChild;
  root.style.height = "calc(100%% - %(height)s)";
  root.style.position = "relative";
  document.title = %(title)s;
  new MutationObserver(function () {
    if (document.title !== %(title)s) document.title = %(title)s;
  }).observe(document.querySelector("title"), {childList: true});
  const keys = [" ", "ArrowLeft", "ArrowRight", "Home", "End", "Delete", "Backspace", "k", "K"];
  window.addEventListener("keydown", function (event) {
    const t = event.target;
    if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.isContentEditable)) return;
    const ctrl = event.ctrlKey || event.metaKey;
    const ours = keys.includes(event.key) || (ctrl && "zZyYcCvV".includes(event.key));
    if (!ours) return;
    event.preventDefault();
    frame.contentWindow.postMessage({choreoKey: {key: event.key, shiftKey: event.shiftKey,
      ctrlKey: event.ctrlKey, metaKey: event.metaKey, altKey: event.altKey}}, "*");
  }, true);
})();
"""


def frame_html(title: str) -> str:
    """The HTML for viser's page that frames the timeline (served under ``ROOT`` on the same
    address)."""
    script = _FRAME_SCRIPT % {
        "root": json.dumps(ROOT),
        "height": TIMELINE_HEIGHT,
        "title": json.dumps(title),
    }
    handler = script.replace("&", "&amp;").replace('"', "&quot;")
    return f'<img src="data:," alt="" style="display: none" onerror="{handler}">'
