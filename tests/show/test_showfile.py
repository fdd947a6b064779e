"""Show files that would pass by accident: a performer given a show file as its motion, offsets
out of reason."""

from __future__ import annotations

from pathlib import Path

import pytest

from choreo.errors import SourceError
from choreo.show.showfile import MAX_OFFSET_S, is_show_file, load_show
from choreo.validate import check_file

SHOWS = Path(__file__).resolve().parents[1] / "data" / "shows"


def test_a_motion_that_is_a_show_file_is_refused_at_its_line(tmp_path):
    path = tmp_path / "show.yaml"
    path.write_text(f"performers:\n  - {{name: a, motion: {SHOWS / 'duo.yaml'}}}\n")
    with pytest.raises(SourceError) as raised:
        load_show(path)
    assert raised.value.problems == [
        f"{path}:2:23: motion: {SHOWS / 'duo.yaml'} is a show file, not a motion; a performer "
        "dances a motion file"
    ]
    assert check_file(path, physics=False).problems == raised.value.problems


def test_a_show_that_names_itself_is_one_problem_not_a_loop(tmp_path):
    path = tmp_path / "show.yaml"
    path.write_text("performers:\n  - {name: a, motion: show.yaml}\n")
    assert len(check_file(path, physics=False).problems) == 1


@pytest.mark.parametrize(
    "offset, problem",
    [
        ("offset_s: 3600.5", "offset_s must be in 0..3600, got 3600.5"),
        ("offset_beats: 1.0e+308", "offset_beats 1e+308 at 120 BPM starts the part inf s"),
        ("offset_beats: 7201", "offset_beats 7201 at 120 BPM starts the part 3600.5 s"),
    ],
)
def test_an_offset_past_an_hour_is_refused(tmp_path, offset, problem):
    (tmp_path / "song.wav").write_bytes(b"")
    path = tmp_path / "show.yaml"
    path.write_text(
        "music: {song: song.wav, bpm: 120}\n"
        f"performers:\n  - {{name: a, motion: {SHOWS / 'nod.yaml'}, {offset}}}\n"
    )
    with pytest.raises(SourceError) as raised:
        load_show(path)
    [line] = raised.value.problems
    assert line.startswith(f"{path}:3:") and problem in line, line


def test_offsets_up_to_an_hour_are_taken(tmp_path):
    path = tmp_path / "show.yaml"
    path.write_text(
        f"performers:\n  - {{name: a, motion: {SHOWS / 'nod.yaml'}, offset_s: {MAX_OFFSET_S}}}\n"
    )
    assert load_show(path).parts[0].offset_s == MAX_OFFSET_S


def test_a_show_file_is_told_from_a_motion():
    assert is_show_file(SHOWS / "duo.yaml")
    assert not is_show_file(SHOWS / "nod.yaml")
