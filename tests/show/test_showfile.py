"""Show files that would pass by accident: a performer given a show file as its motion, offsets
out of reason."""

from __future__ import annotations

import pytest
from paths import DATA

from choreo.errors import SourceError
from choreo.show.showfile import MAX_OFFSET_S, is_show_file, load_show
from choreo.validate import check_file

SHOWS = DATA / "shows"


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


def test_cues_are_numbered_parts_played_one_after_another():
    show = load_show(SHOWS / "cues.yaml")
    assert [(c.number, c.name, [p.performer for p in c.parts]) for c in show.cues] == [
        (1, "opening", ["left"]),
        (2, "cue 2", ["left", "right"]),
    ]
    assert [p.performer for p in show.parts] == ["left", "left", "right"]  # all validated
    played = show.in_cues()
    assert [s.name for s in played] == ["cues, cue 1 (opening)", "cues, cue 2 (cue 2)"]
    assert [[p.offset_s for p in s.parts] for s in played] == [[0.0], [0.0, 0.25]]
    assert check_file(SHOWS / "cues.yaml", physics=False).ok


def test_a_show_without_cues_is_its_own_one_cue():
    show = load_show(SHOWS / "duo.yaml")
    assert show.cues == () and show.in_cues() == [show]


@pytest.mark.parametrize(
    "text, problem",
    [
        ("name: x\n", "give either performers (played together) or cues"),
        (f"performers: [{{name: a, motion: {SHOWS / 'nod.yaml'}}}]\ncues: []\n", "give either"),
        ("cues: []\n", "cues is empty; give at least one"),
        ("cues:\n  - {name: one}\n", "cue 1 is missing 'performers'"),
    ],
)
def test_a_show_needs_performers_or_cues(tmp_path, text, problem):
    path = tmp_path / "show.yaml"
    path.write_text(text)
    with pytest.raises(SourceError) as raised:
        load_show(path)
    assert any(problem in line for line in raised.value.problems), raised.value.problems
