"""What a studio's parts share: a note or a refusal goes to the terminal (with its glyph) and to
the one status line, after the files' state, until the next action says something else."""

from __future__ import annotations

from studio_helpers import studio_on


def test_a_note_replaces_the_last_refusal_on_the_status_line(tmp_path):
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        studio.refuse("refused: nothing to undo")
        studio.note("added keyframe 3")
        assert studio.said[-2:] == ["⛔ refused: nothing to undo", "added keyframe 3"]
        status = studio.page.status.content
        assert "added keyframe 3" in status and "nothing to undo" not in status
        assert "#b00020" not in status  # a note is not in the refusal's colour
