"""The studio's journal on its own: undo and redo restore the bytes written, and refuse to
write over a file that changed since."""

from __future__ import annotations

import pytest

from choreo.studio.journal import Journal, JournalRefused


def test_undo_and_redo_walk_the_writes_and_a_new_write_forgets_what_was_undone(tmp_path):
    path = tmp_path / "m.yaml"
    journal = Journal(path)
    versions = [b"a\r\n", b"a\r\nb\n", b"a\r\nb\nc"]  # line endings and a last line kept
    path.write_bytes(versions[0])
    for before, after in zip(versions, versions[1:]):
        path.write_bytes(after)
        journal.record(before, after, f"wrote {len(after)}")
    assert (journal.can_undo, journal.can_redo) == (True, False)
    assert journal.undo().what == "wrote 6"
    assert path.read_bytes() == versions[1]
    journal.undo()
    assert path.read_bytes() == versions[0] and not journal.can_undo
    assert journal.redo().what == "wrote 5"
    assert path.read_bytes() == versions[1]

    path.write_bytes(b"x")  # a write of the page forgets the undone ones
    journal.record(versions[1], b"x", "wrote x")
    assert not journal.can_redo
    with pytest.raises(JournalRefused, match="^nothing to redo: no write was undone"):
        journal.redo()


def test_an_outside_edit_is_never_overwritten(tmp_path):
    path = tmp_path / "m.yaml"
    journal = Journal(path)
    with pytest.raises(JournalRefused, match="^nothing to undo"):
        journal.undo()
    path.write_bytes(b"new")
    journal.record(b"old", b"new", "added a keyframe")
    path.write_bytes(b"new, then saved in an editor")
    with pytest.raises(JournalRefused) as refused:
        journal.undo()
    assert str(refused.value) == (
        f"cannot undo added a keyframe: {path} changed on disk since the studio wrote it; "
        "the outside edit stays (undo it in the editor that made it)"
    )
    assert path.read_bytes() == b"new, then saved in an editor"
    assert journal.can_undo  # still there, should the editor put the file back
    path.write_bytes(b"new")
    journal.undo()
    assert path.read_bytes() == b"old"

    path.unlink()
    with pytest.raises(JournalRefused, match=f"^cannot redo added a keyframe: {path}: "):
        journal.redo()


def test_writes_in_one_step_are_undone_and_redone_together_unless_an_outside_edit_came_between(
    tmp_path,
):
    path = tmp_path / "m.yaml"
    journal = Journal(path)
    path.write_bytes(b"a")
    journal.record(b"", b"a", "added a")
    with journal.one_step("moved 3 keyframes"):
        for before, after in ((b"a", b"ab"), (b"ab", b"abc"), (b"abc", b"abcd")):
            path.write_bytes(after)
            journal.record(before, after, "moved the keyframe")
    assert journal.undo().what == "moved 3 keyframes"
    assert path.read_bytes() == b"a"
    assert journal.redo().what == "moved 3 keyframes"
    assert path.read_bytes() == b"abcd"

    with journal.one_step("deleted 2 keyframes"):  # saved in an editor between the two
        journal.record(b"abcd", b"abc", "deleted the keyframe")
        journal.record(b"abc, edited", b"ab, edited", "deleted the keyframe")
    path.write_bytes(b"ab, edited")
    assert journal.undo().what == "deleted the keyframe"
    assert path.read_bytes() == b"abc, edited"
    with pytest.raises(JournalRefused, match="changed on disk"):  # never over the outside edit
        journal.undo()
