"""The song in the studio's page: the file's own bytes in an <audio> element that follows the
timeline, or one line saying why it is not played."""

from __future__ import annotations

import base64
import functools
import re
from dataclasses import replace

from choreo.motion.motion_file import load_motion
from choreo.studio.song import MAX_SONG_BYTES, song_html


@functools.cache
def dance_music():
    return load_motion("motions/arm6/dance.yaml").music


def music(song, start_s=0.25):
    return replace(dance_music(), song=song, start_s=start_s)


def test_the_song_is_in_the_page_as_its_own_bytes_and_starts_at_the_music_start(tmp_path):
    song = tmp_path / "groove.ogg"
    song.write_bytes(b"OggS not really a song")
    html = song_html(music(song))
    [data] = re.findall(r'src="data:audio/ogg;base64,([^"]+)"', html)
    assert base64.b64decode(data) == song.read_bytes()
    assert "const offset = 0.25," in html


def test_a_file_the_page_cannot_play_is_named_with_the_reason(tmp_path):
    midi = tmp_path / "tune.mid"
    midi.write_bytes(b"MThd")
    assert song_html(music(midi)) == "<p>tune.mid: a .mid file, not played in the page</p>"
    big = tmp_path / "long.wav"
    with big.open("wb") as out:
        out.truncate(MAX_SONG_BYTES + 1)
    assert song_html(music(big)) == "<p>long.wav: too large, not played in the page</p>"
