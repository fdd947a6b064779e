"""Motion files: keyframes for a robot, read with every mistake located, and written back.

- :mod:`~choreo.motion.motion_file`: :func:`load_motion`, :class:`Motion`, :class:`Keyframe`;
  :mod:`~choreo.motion.keyframe_list`: the ``keyframes:`` list and the files it includes;
  :mod:`~choreo.motion.keyframe_entry`: one keyframe entry as written (pose, timing, space);
- :mod:`~choreo.motion.timing`: the keyframe timing rules (t, after, hold, repeat, speed);
- :mod:`~choreo.motion.music_block`: the ``music:`` block, beats and bars to seconds;
- :mod:`~choreo.motion.dance`: a motion as danced: looped, and held against its song;
- :mod:`~choreo.motion.scene`: how a motion starts (standing, lying) and its props;
- :mod:`~choreo.motion.spatial`, :mod:`~choreo.motion.gait`: keyframes in space (sites, body
  poses, gaits), turned into joint angles;
- :mod:`~choreo.motion.mirror`, :mod:`~choreo.motion.writer`: mirrored motions, motion files
  written.
"""

from __future__ import annotations

from choreo.motion.motion_file import Keyframe, Motion, load_motion

__all__ = ["Keyframe", "Motion", "load_motion"]
