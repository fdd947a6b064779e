"""What the timeline's page may ask: its JSON read into requests, and a bad one refused with
one line."""

from __future__ import annotations

import pytest

from choreo.studio.timeline_requests import RequestError, parse_request


def test_the_pages_requests_are_read_and_bad_ones_refused_with_a_line():
    move = parse_request(b'{"op": "move", "moves": [{"index": 2, "t": 2.5}], "version": 4}')
    assert (move.op, move.version, move.placed[0].index, move.placed[0].t_s) == ("move", 4, 2, 2.5)
    paste = parse_request(b'{"op": "paste", "keyframes": [{"t": 1, "pose": {"elbow": 40}}]}')
    assert paste.placed[0].pose == {"elbow": 40.0}
    assert parse_request(b'{"op": "scrub", "t": 1.25}').t_s == 1.25
    assert parse_request(b'{"op": "delete", "indices": [3, 1]}').indices == (3, 1)
    for bad in (
        b"not json",
        b'{"op": "explode"}',
        b'{"op": "scrub", "t": "soon"}',
        b'{"op": "scrub", "t": NaN}',
        b'{"op": "delete", "indices": [-1]}',
        b'{"op": "move", "moves": []}',
        b'{"op": "paste", "keyframes": [{"t": 1, "pose": {"elbow": "up"}}]}',
        b'{"op": "select", "indices": [1], "version": true}',
    ):
        with pytest.raises(RequestError) as refused:
            parse_request(bad)
        assert "\n" not in str(refused.value)
