"""The timeline's page component served beside viser's, under /timeline/: its files, its events
in order, the page's requests taken one at a time, and a bad request refused with one line."""

from __future__ import annotations

import json
import threading
import urllib.error
import urllib.request

import pytest

from choreo.studio.timeline_requests import Request
from choreo.studio.timeline_server import Broadcast, TimelineServer, frame_html


def test_the_broadcast_gives_each_page_the_newest_event_of_each_kind_in_order():
    events = Broadcast()
    events.publish("time", {"t": 1})
    events.publish("state", {"version": 1})
    events.publish("time", {"t": 2})  # replaces the first time: only the newest matters
    seen, fresh = events.newer(0, timeout_s=0.0)
    assert seen == 3 and fresh == [("state", '{"version":1}'), ("time", '{"t":2}')]
    assert events.newer(seen, timeout_s=0.0) == (3, [])
    events.close()
    assert events.closed


def test_the_server_serves_the_page_and_hands_on_the_requests_it_can_read():
    taken: list[Request] = []
    arrived = threading.Event()

    def on_request(request: Request) -> None:
        taken.append(request)
        arrived.set()

    server = TimelineServer(on_request, song=lambda: None)
    server.start()
    base = f"http://127.0.0.1:{server.port}/timeline"  # the paths the front passes on
    try:
        with urllib.request.urlopen(f"{base}/") as page:
            assert b"<canvas" in page.read()
            # one request a connection: the front routes a connection by its first request
            assert page.headers["Connection"] == "close"
        with pytest.raises(urllib.error.HTTPError) as elsewhere:
            urllib.request.urlopen(f"http://127.0.0.1:{server.port}/timeline.js")  # viser's
        assert elsewhere.value.code == 404

        def post(body: bytes) -> int:
            request = urllib.request.Request(f"{base}/command", data=body, method="POST")
            try:
                with urllib.request.urlopen(request) as answer:
                    return answer.status
            except urllib.error.HTTPError as error:
                return error.code

        assert post(json.dumps({"op": "scrub", "t": 1.5}).encode()) == 204
        assert arrived.wait(5.0) and taken == [Request("scrub", 1.5)]
        assert post(b"not json") == 400
        with pytest.raises(urllib.error.HTTPError) as missing:
            urllib.request.urlopen(f"{base}/song")
        assert missing.value.code == 404
    finally:
        server.close()
    assert taken == [Request("scrub", 1.5)]


def test_the_frame_runs_its_script_from_an_image_that_fails_to_load():
    html = frame_html("choreo studio")
    head = '<img src="data:," alt="" style="display: none" onerror="'
    assert html.startswith(head) and html.endswith('">')
    script = html[len(head) : -2]
    assert '"' not in script and "%(" not in script  # all escaped and filled in
    assert "frame.src = &quot;/timeline/&quot;;" in script  # on the page's own address
