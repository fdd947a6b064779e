"""The timeline at the bottom of the studio's page: a page component of its own (``web/``:
HTML, a canvas and a script; no build step, nothing fetched from elsewhere), served beside
viser's page and framed into it full width at the bottom.

viser's GUI lays controls out in a side panel; lanes of keyframe diamonds, a waveform and curves
under one playhead need a canvas. A small HTTP server of the studio's own (on viser's host, a
port the system picks) serves the component's files, the song, the state as Server-Sent Events
(``state``, ``play``, ``time``, ``status``), and takes the page's requests as posted JSON
(``Request``). What the timeline shows is built here from a ``Plan`` (``timeline_state``).
"""

from __future__ import annotations

import json
import logging
import math
import queue
import threading
from collections.abc import Callable, Mapping, Sequence, Sized
from dataclasses import dataclass
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from choreo.motion.music_block import Music
from choreo.studio.session import Plan, Reload
from choreo.studio.watch import stamp

if TYPE_CHECKING:
    from choreo.studio.server import Studio

log = logging.getLogger(__name__)

CURVE_POINTS = 2000  # samples per joint's curve: a few per pixel of a wide screen
PEAKS_PER_S = 50  # the waveform's resolution: one peak per 20 ms of song
PEAK_RATE_HZ = 8000  # the song is decoded this finely for its waveform
MAX_REQUEST_BYTES = 1_000_000
KEEP_ALIVE_S = 15.0
FILES = {  # what the component's server serves from web/: path -> (file, content type)
    "/": ("timeline.html", "text/html; charset=utf-8"),
    "/timeline.js": ("timeline.js", "text/javascript; charset=utf-8"),
    "/timeline.css": ("timeline.css", "text/css; charset=utf-8"),
}
SONG_TYPES = {".ogg": "audio/ogg", ".mp3": "audio/mpeg", ".wav": "audio/wav", ".flac": "audio/flac"}
OPS = ("scrub", "play", "select", "finding", "move", "delete", "add", "paste", "undo", "redo")


class RequestError(ValueError):
    """A request the timeline's page should not have sent: one line that says what is wrong."""


@dataclass(frozen=True)
class Placed:
    """A keyframe asked for at a time: moved there (``index``) or pasted there (``pose``)."""

    t_s: float
    index: int | None = None
    pose: Mapping[str, float] | None = None


@dataclass(frozen=True)
class Request:
    """What the timeline's page asks the studio; ``version`` is the state it saw (the reload
    its keyframe indices refer to), None for requests that name no keyframe."""

    op: str
    t_s: float | None = None
    indices: tuple[int, ...] = ()
    placed: tuple[Placed, ...] = ()
    version: int | None = None


def parse_request(body: bytes) -> Request:
    """The page's posted JSON as a ``Request``; ``RequestError`` if it is not one."""
    try:
        data = json.loads(body)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RequestError(f"a request that is not JSON: {error}") from None
    if not isinstance(data, dict) or data.get("op") not in OPS:
        raise RequestError(f"a request needs an op, one of {', '.join(OPS)}")
    op = data["op"]
    version = data.get("version")
    if version is not None and not _is_int(version):
        raise RequestError(f"{op}: version {version!r} is not a whole number")
    t = data.get("t")
    if op == "scrub" and not _is_number(t):
        raise RequestError(f"scrub: t {t!r} is not a number of seconds")
    indices = data.get("indices", [])
    if not isinstance(indices, list) or not all(_is_int(i) and i >= 0 for i in indices):
        raise RequestError(f"{op}: indices {indices!r} are not keyframe numbers")
    if op == "finding" and not _is_int(data.get("index")):
        raise RequestError(f"finding: index {data.get('index')!r} is not a finding's number")
    if op == "finding":
        indices = [data["index"]]
    placed: tuple[Placed, ...] = ()
    if op == "move":
        placed = tuple(_placed(op, m, "index") for m in _list(op, data, "moves"))
    elif op == "paste":
        placed = tuple(_placed(op, k, "pose") for k in _list(op, data, "keyframes"))
    t_s = float(t) if isinstance(t, int | float) and _is_number(t) else None
    return Request(op, t_s, tuple(indices), placed, version)


def _list(op: str, data: dict, key: str) -> list:
    items = data.get(key)
    if not isinstance(items, list) or not items:
        raise RequestError(f"{op}: {key} is not a list of keyframes")
    return items


def _placed(op: str, item: Any, key: str) -> Placed:
    if not isinstance(item, dict) or not _is_number(item.get("t")):
        raise RequestError(f"{op}: {item!r} has no time t")
    if key == "index":
        if not _is_int(item.get("index")) or item["index"] < 0:
            raise RequestError(f"move: {item!r} names no keyframe index")
        return Placed(float(item["t"]), index=item["index"])
    pose = item.get("pose")
    if not isinstance(pose, dict) or not all(
        isinstance(k, str) and _is_number(v) for k, v in pose.items()
    ):
        raise RequestError(f"paste: {item!r} has no pose of joint angles")
    return Placed(float(item["t"]), pose={k: float(v) for k, v in pose.items()})


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


# --- what the timeline shows -------------------------------------------------------------------


def timeline_state(
    plan: Plan,
    version: int,
    limbs: Sequence[tuple[str, Sequence[int]]],
    peaks: Sequence[int] = (),
) -> dict:
    """Everything the timeline draws of ``plan`` (reload ``version``), as JSON-ready data:
    keyframes with the joints each one changes, the lanes grouped by ``limbs``, the curves,
    the findings with the keyframe each one belongs to, and the music's beats and ``peaks``."""
    motion, robot = plan.motion, plan.motion.robot
    times = plan.keyframe_times_s
    own = Path(motion.path).resolve()
    keyframes = []
    previous: tuple[float, ...] | None = None
    for keyframe, t in zip(motion.keyframes, times):
        changed = [
            j
            for j, angle in enumerate(keyframe.targets_deg)
            if previous is None or abs(angle - previous[j]) > 1e-6
        ]
        previous = keyframe.targets_deg
        where = keyframe.where
        keyframes.append(
            {
                "t": round(t, 4),
                "where": f"{Path(where.path).name}:{where.line}",
                "label": keyframe.label,
                "joints": changed,
                "editable": Path(where.path).resolve() == own and not where.included_at,
                "pose": {n: round(a, 3) for n, a in zip(robot.joint_names, keyframe.targets_deg)},
            }
        )
    return {
        "version": version,
        "file": Path(motion.path).name,
        "start_s": round(plan.start_s, 4),
        "end_s": round(plan.end_s, 4),
        "keyframes": keyframes,
        "joints": [
            {"name": j.name, "min": j.limits.min_deg, "max": j.limits.max_deg} for j in robot.joints
        ],
        "limbs": [{"name": name, "joints": list(joints)} for name, joints in limbs],
        "curves": _curves(plan),
        "findings": [
            {
                "t": round(f.time_s, 4),
                "duration_s": round(f.duration_s, 4),
                "severity": f.severity.value,
                "message": f.message,
                "keyframe": keyframes[keyframe_of(times, f.time_s)]["where"] if keyframes else "",
            }
            for f in plan.findings
        ],
        "music": _music(motion.music, version, peaks),
    }


def keyframe_of(times_s: Sequence[float], t_s: float) -> int:
    """The keyframe a moment belongs to: the one the motion is moving to (or holding) then."""
    later = int(np.searchsorted(np.asarray(times_s), t_s - 1e-6))
    return min(later, len(times_s) - 1)


def _curves(plan: Plan) -> dict:
    every = max(1, math.ceil(len(plan.times_s) / CURVE_POINTS))
    times = plan.times_s[::every]
    planned = plan.command_deg[::every]
    curves: dict[str, Any] = {
        "t": np.round(times, 4).tolist(),
        "plan": np.round(planned.T, 2).tolist(),
        "sim": None,
    }
    if plan.physics is not None:
        curves["sim"] = np.round(plan.physics.simulated_deg(times).T, 2).tolist()
    return curves


def _music(music: Music | None, version: int, peaks: Sequence[int]) -> dict | None:
    if music is None:
        return None
    grid = music.grid
    return {
        "name": music.song.name,
        "offset_s": music.start_s,
        "beats": [round(t, 4) for t in grid.beat_times_s],
        "beats_per_bar": grid.beats_per_bar,
        "bar_one_beat": grid.bar_one_beat,
        "peaks_per_s": PEAKS_PER_S,
        "peaks": list(peaks),
        "song_url": f"song?v={version}",
    }


def song_peaks(music: Music | None) -> tuple[int, ...]:
    """The song's loudness, 0..100, every 1/PEAKS_PER_S s (nothing if it can't be decoded)."""
    if music is None:
        return ()
    from choreo.errors import ChoreoError
    from choreo.music.decode import decode_song

    try:
        audio = decode_song(music.song, rate_hz=PEAK_RATE_HZ)
    except ChoreoError as error:
        log.warning("no waveform for %s: %s", music.song, error)
        return ()
    samples = np.abs(np.asarray(audio.samples, dtype=float))
    if samples.ndim > 1:
        samples = samples.max(axis=1)
    per = max(1, audio.rate_hz // PEAKS_PER_S)
    count = len(samples) // per
    if count == 0:
        return ()
    peaks = samples[: count * per].reshape(count, per).max(axis=1)
    top = float(peaks.max()) or 1.0
    return tuple(int(round(p)) for p in peaks / top * 100)


# --- serving ---------------------------------------------------------------------------------


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
    """Serves the timeline's page on ``host`` (a free port); ``on_request`` hears its requests
    (from the server's threads), ``song`` names the song file to serve."""

    def __init__(
        self,
        host: str,
        on_request: Callable[[Request], None],
        song: Callable[[], Path | None],
    ):
        self.events = Broadcast()
        self._on_request = on_request
        self._song = song
        handler = type("Handler", (_Handler,), {"timeline": self})
        self._http = ThreadingHTTPServer((host, 0), handler)
        self._http.daemon_threads = True
        self.port = int(self._http.server_address[1])
        self._thread = threading.Thread(
            target=self._http.serve_forever, name="studio-timeline", daemon=True
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
        elif path == "/events":
            self._stream_events()
        elif path == "/song":
            self._send_song()
        else:
            self._send(HTTPStatus.NOT_FOUND, "text/plain", b"not found")

    def do_POST(self) -> None:  # noqa: N802
        if self.path != "/command":
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

    def _stream_events(self) -> None:
        self.send_response(HTTPStatus.OK)
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
        self.close_connection = True


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
  frame.src = location.protocol + "//" + location.hostname + ":%(port)d/";
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


def frame_html(port: int, title: str) -> str:
    """The HTML for viser's page that frames the timeline served on ``port``."""
    script = _FRAME_SCRIPT % {
        "port": port,
        "height": TIMELINE_HEIGHT,
        "title": json.dumps(title),
    }
    handler = script.replace("&", "&amp;").replace('"', "&quot;")
    return f'<img src="data:," alt="" style="display: none" onerror="{handler}">'


# --- the studio's side ---------------------------------------------------------------------------


class TimelinePage:
    """The studio's timeline page: what it shows (``show_*``, from the studio's threads) and
    what it asks, done with the studio's own operations (select, scrub, move here, delete,
    add, undo), so an edit from the timeline is the edit the panel's buttons make, checked
    and journalled the same way."""

    def __init__(self, host: str, studio: Studio):
        self._studio = studio
        self.server = TimelineServer(host, self.handle, self._song)
        self._peaks: tuple[tuple | None, tuple[int, ...]] = (None, ())

    @property
    def port(self) -> int:
        return self.server.port

    def start(self) -> None:
        self.server.start()

    def close(self) -> None:
        self.server.close()

    def _song(self) -> Path | None:
        plan = self._studio.session.plan
        return plan.motion.music.song if plan is not None and plan.motion.music else None

    def show_plan(self, plan: Plan, version: int, limbs: Sequence[tuple[str, Sequence[int]]]):
        state = timeline_state(plan, version, limbs, self._song_peaks(plan.motion.music))
        self.server.publish("state", state)

    def _song_peaks(self, music: Music | None) -> tuple[int, ...]:
        key = None if music is None else (music.song, stamp(music.song))
        if key != self._peaks[0]:
            self._peaks = (key, song_peaks(music))
        return self._peaks[1]

    def show_time(self, t_s: float) -> None:
        self.server.publish("time", {"t": round(t_s, 4)})

    def show_play(self, playing: bool, t_s: float, speed: float) -> None:
        self.server.publish("play", {"playing": playing, "t": round(t_s, 4), "speed": speed})

    def show_status(self, text: str, kind: str = "") -> None:
        self.server.publish("status", {"text": text, "kind": kind})

    # --- what the page asks ----------------------------------------------------------------

    def handle(self, request: Request) -> None:
        studio = self._studio
        if request.version is not None and request.version != studio.session.version:
            studio.refuse(
                f"{request.op}: the page showed reload {request.version}, the file is now at "
                f"reload {studio.session.version}: look again, then {request.op} again"
            )
            return
        if request.op == "scrub" and request.t_s is not None:
            studio.scrub(request.t_s)
        elif request.op == "play":
            studio.toggle_play()
        elif request.op == "select":
            self._select(request.indices)
        elif request.op == "finding":
            self._name_finding(request.indices[0])
        elif request.op == "move":
            self._move([(p.index, p.t_s) for p in request.placed if p.index is not None])
        elif request.op == "delete":
            self._delete(request.indices)
        elif request.op == "add":
            studio.add_keyframe()
        elif request.op == "paste":
            self._paste([(p.t_s, p.pose) for p in request.placed if p.pose is not None])
        elif request.op == "undo":
            studio.undo()
        elif request.op == "redo":
            studio.redo()

    def _keyframes(self) -> int:
        plan = self._studio.session.plan
        return len(plan.motion.keyframes) if plan is not None else 0

    def _select(self, indices: Sequence[int]) -> None:
        """One keyframe selected is the panel's selection too (Update acts on it); several,
        or none, leave the panel none."""
        studio, count = self._studio, self._keyframes()
        if any(i >= count for i in indices):
            studio.refuse(f"refused: the motion has {count} keyframes, not {max(indices) + 1}")
            return
        studio.select_keyframe(indices[0] if len(indices) == 1 else None)

    def _name_finding(self, index: int) -> None:
        """A finding clicked: the playhead goes there; the status line says it and the
        keyframe it belongs to."""
        studio = self._studio
        plan = studio.session.plan
        if plan is None or index >= len(plan.findings):
            studio.refuse(f"refused: there is no finding {index + 1}")
            return
        finding = plan.findings[index]
        keyframe = plan.motion.keyframes[keyframe_of(plan.keyframe_times_s, finding.time_s)]
        studio.scrub(finding.time_s)
        studio.note(
            f"{finding.time_s:.2f} s {finding.severity.value}: {finding.message} "
            f"(keyframe at {keyframe.where})"
        )

    def _done(self, edit: Callable[[], None]) -> bool:
        """Make one edit; whether it was written (the file reloaded)."""
        version = self._studio.session.version
        edit()
        return self._studio.session.version != version

    def _move(self, moves: Sequence[tuple[int, float]]) -> None:
        """Keyframes dragged (index, to time s), each moved as Move keyframe here does: those
        moving later from the last, those moving earlier from the first, so none passes
        another on the way; the first refusal stops the rest. One step to undo."""
        studio = self._studio
        plan = studio.session.plan
        if plan is None or any(i >= len(plan.keyframe_times_s) for i, _ in moves):
            studio.refuse(f"refused: the motion has {self._keyframes()} keyframes")
            return
        later = bool(moves) and moves[0][1] > plan.keyframe_times_s[moves[0][0]]
        with studio.journal.one_step(f"moved {count(moves, 'keyframe')}"):
            for index, t_s in sorted(moves, reverse=later):
                studio.select_keyframe(index)
                studio.scrub(t_s)
                if not self._done(studio.retime_keyframe):
                    return

    def _delete(self, indices: Sequence[int]) -> None:
        """Keyframes deleted as Delete keyframe does, the last first (the numbers of the
        others stay). One step to undo."""
        studio = self._studio
        if any(i >= self._keyframes() for i in indices):
            studio.refuse(f"refused: the motion has {self._keyframes()} keyframes")
            return
        with studio.journal.one_step(f"deleted {count(set(indices), 'keyframe')}"):
            for index in sorted(set(indices), reverse=True):
                studio.select_keyframe(index)
                if not self._done(studio.delete_keyframe):
                    return

    def _paste(self, keyframes: Sequence[tuple[float, Mapping[str, float]]]) -> None:
        """Copied poses (time s, joint -> degrees) added as Add keyframe does, earliest first.
        One step to undo."""
        studio = self._studio
        with studio.journal.one_step(f"pasted {count(keyframes, 'keyframe')}"):
            for t_s, pose in sorted(keyframes, key=lambda k: k[0]):
                studio.scrub(t_s)
                if not studio.take_angles(pose) or not self._done(studio.add_keyframe):
                    return


def count(things: Sized, noun: str) -> str:
    """ "3 keyframes", "1 keyframe"."""
    return f"{len(things)} {noun}{'s' * (len(things) != 1)}"


def reload_status(result: Reload, plan: Plan | None) -> tuple[str, str]:
    """The status line's first part after a reload, and its kind ("failed" or "")."""
    if result.problems:
        kept = " (the last good plan stays on screen)" if plan is not None else ""
        more = len(result.problems) - 1
        first = result.problems[0] + (f" (and {more} more, listed below)" if more else "")
        return f"reload {result.version} failed: {first}{kept}", "failed"
    assert plan is not None
    physics = plan.physics
    if physics is None:
        return f"reload {result.version} planned: {plan.end_s:.2f} s; simulating…", ""
    findings = physics.findings
    errors = sum(f.severity.value == "error" for f in findings)
    found = (
        f"{len(findings)} finding{'s' * (len(findings) != 1)}"
        + (f" ({errors} error{'s' * (errors != 1)})" if errors else "")
        if findings
        else "no findings: the simulated robot follows the plan"
    )
    took = f"simulated in {physics.took_s:.2f} s"
    return f"reload {result.version} {took}: {plan.end_s:.2f} s, {found}", ""
