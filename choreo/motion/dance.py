"""A motion as it will be danced: loaded from its file, played ``loop`` times instead of its
file's ``repeat``, and held against its song.

A dance that outlasts its song is refused unless ``allow_past_song``: at the motion file's line
when it is loaded (``load_motion``), naming ``loop`` when the loop makes it so. Allowed, it is
said (``on_note``), as is which detected beats ``beats: auto`` took. Play, plan and preview
all load a dance this way.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Callable

from choreo.core.arguments import COUNT, check_optional_number
from choreo.errors import OptionError
from choreo.motion.motion_file import Motion, motion_of, too_many_played
from choreo.motion.music_block import past_song

log = logging.getLogger(__name__)


def dance_of(
    motion: Motion | str | os.PathLike[str],
    allow_past_song: bool = False,
    *,
    loop: int | None = None,
    on_note: Callable[[str], None] = log.warning,
) -> Motion:
    """``motion``, loaded when given by its path, played ``loop`` times when given. A Motion
    given as it is was checked against its song when it was loaded, and is not again unless
    looped here."""
    check_optional_number("loop", loop, COUNT)
    loaded = not isinstance(motion, Motion)
    motion = motion_of(motion, allow_past_song)
    if loaded and motion.music is not None and motion.music.note:
        on_note(motion.music.note)  # which detected beats beats: auto took
    if loop is not None:
        motion = _looped(motion, loop)
    elif not loaded:
        return motion
    outlasting = past_song(motion.music, motion.keyframes, motion.repeat)
    if outlasting is None:
        return motion
    if not allow_past_song:  # looped: a file's own repeat was refused at its line
        raise OptionError(
            "loop",
            f"{loop}: {outlasting}; loop fewer times, or pass {{allow_past_song}} to dance on "
            "in silence",
            mentions=("allow_past_song",),
        )
    on_note(f"warning: {outlasting}: the dance goes on in silence")
    return motion


def _looped(motion: Motion, loop: int) -> Motion:
    problem = too_many_played(len(motion.keyframes), loop, "loop")
    if problem is not None:
        raise OptionError("loop", problem.removeprefix("loop "))
    return dataclasses.replace(motion, repeat=loop)
