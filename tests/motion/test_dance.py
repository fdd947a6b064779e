"""choreo.motion.dance: a motion as it will be danced, looped and held against its song."""

from __future__ import annotations

import textwrap

import pytest
from music_helpers import steady_times, write_clicks

from choreo.errors import OptionError, SourceError
from choreo.motion.dance import dance_of
from choreo.motion.motion_file import load_motion

# a repetition is 3 bars (beat 9 is in bar 3): one fits the 10 s song, three run past it
DANCE = """
    robot: arm6
    repeat: {repeat}
    music: {{song: song.wav, start: 0.5, bpm: 120}}
    keyframes:
      - pose: home
        beat: 1
      - pose: {{shoulder: 20}}
        beat: 9
    """
PAST = "the dance (repeat 3) runs to at least t 16.000 s, 6.500 s past the end of song.wav"


@pytest.fixture
def dance(tmp_path):
    """A motion file dancing once to a 10 s click track at 120 BPM; a function giving it with
    another repeat."""
    write_clicks(tmp_path / "song.wav", steady_times(120, 0.5, 9.6), 10.0)

    def with_repeat(repeat: int = 1):
        path = tmp_path / f"dance{repeat}.yaml"
        path.write_text(textwrap.dedent(DANCE.format(repeat=repeat)).lstrip())
        return path

    return with_repeat


def test_a_path_is_loaded_and_looped(tmp_path):
    path = tmp_path / "nod.yaml"
    path.write_text("robot: arm6\nkeyframes:\n  - pose: home\n  - pose: {shoulder: 20}\n")
    motion = dance_of(path, loop=4)
    assert (motion.path, motion.repeat, len(motion.keyframes)) == (path, 4, 2)


def test_a_loop_past_the_song_is_refused_naming_loop_unless_allowed(dance):
    with pytest.raises(OptionError) as refused:
        dance_of(dance(), loop=3)
    assert (refused.value.option, refused.value.mentions) == ("loop", ("allow_past_song",))
    assert refused.value.problem.startswith(f"3: {PAST}")
    notes: list[str] = []
    motion = dance_of(dance(), True, loop=3, on_note=notes.append)
    assert motion.repeat == 3
    assert len(notes) == 1 and notes[0].startswith(f"warning: {PAST}")
    assert notes[0].endswith(": the dance goes on in silence")


def test_a_file_past_its_song_is_refused_at_its_line_and_allowed_said(dance):
    with pytest.raises(SourceError) as refused:
        dance_of(dance(3))
    assert refused.value.problems[0].startswith(f"{dance(3)}:2:1: {PAST}")
    notes: list[str] = []
    assert dance_of(dance(3), True, on_note=notes.append).repeat == 3
    assert [n.startswith(f"warning: {PAST}") for n in notes] == [True]


def test_a_motion_given_as_it_is_is_not_checked_again_unless_looped(dance):
    notes: list[str] = []
    motion = load_motion(dance(3), allow_past_song=True)
    assert dance_of(motion, on_note=notes.append) is motion
    assert notes == []
    with pytest.raises(OptionError):
        dance_of(motion, loop=3)


def test_a_loop_is_bounded(dance):
    with pytest.raises(OptionError) as refused:
        dance_of(dance(), loop=10**8)
    assert refused.value.option == "loop"
    assert "at most 10000 are played in one motion" in refused.value.problem
    with pytest.raises(OptionError) as refused:
        dance_of(dance(), loop=0)
    assert refused.value.option == "loop"
