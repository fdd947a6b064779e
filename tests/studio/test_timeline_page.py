"""The timeline page's requests done by the studio as the panel's buttons do them, and the status
line after a reload."""

from __future__ import annotations

from studio_helpers import studio_on, times

from choreo.studio.session import Reload
from choreo.studio.timeline_page import count, reload_status
from choreo.studio.timeline_requests import Placed, Request


def test_keyframes_moved_deleted_or_pasted_together_from_the_timeline_are_one_undo(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        path = studio.session.motion_path
        original = path.read_bytes()
        at = times(studio)
        count = len(at)
        version = studio.session.version
        studio.timeline_page.handle(  # the last two keyframes dragged 0.1 s later together
            Request(
                "move",
                placed=tuple(Placed(at[i] + 0.1, index=i) for i in (count - 2, count - 1)),
                version=version,
            )
        )
        assert times(studio)[-2:] == [round(at[-2] + 0.1, 3), round(at[-1] + 0.1, 3)]
        moved = path.read_bytes()
        studio.undo()
        assert path.read_bytes() == original and times(studio) == at
        studio.redo()
        assert path.read_bytes() == moved

        studio.timeline_page.handle(
            Request("delete", indices=(count - 1, count - 2), version=studio.session.version)
        )
        assert len(times(studio)) == count - 2
        studio.undo()
        assert path.read_bytes() == moved

        studio.timeline_page.handle(
            Request(
                "paste",
                placed=(
                    Placed(at[-1] + 0.6, pose={"elbow": -20}),
                    Placed(at[-1] + 1.6, pose={"elbow": 0}),  # past the end: it extends it
                ),
                version=studio.session.version,
            )
        )
        assert times(studio)[-2:] == [round(at[-1] + 0.6, 3), round(at[-1] + 1.6, 3)]
        studio.undo()
        assert path.read_bytes() == moved
        assert f"undid 'pasted 2 keyframes' in {path}" in studio.said


def test_the_status_line_says_a_failed_reload_keeps_the_last_good_plan():
    text, kind = reload_status(Reload(4, ("m.yaml:3:5: no joint elbw", "m.yaml:4:5: x")), None)
    assert (text, kind) == (
        "reload 4 failed: m.yaml:3:5: no joint elbw (and 1 more, listed below)",
        "failed",
    )
    assert [count(things, "keyframe") for things in ([1], [], "abc")] == [
        "1 keyframe",
        "0 keyframes",
        "3 keyframes",
    ]
