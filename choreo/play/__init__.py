"""Playing on a bus: a motion in one call, or the player's parts one at a time.

- :mod:`~choreo.play.play_motion`: :func:`play_motion`, what ``choreo play`` does;
- :mod:`~choreo.play.play_options`: :class:`PlayOptions`, how a motion is played;
- :mod:`~choreo.play.preflight`: :func:`preflight`, every servo answers and is fit to move;
- :mod:`~choreo.play.player`: :class:`Player`, which plays ticks, stops and leaves the servos;
- :mod:`~choreo.play.stream`: the deadline loop; :mod:`~choreo.play.tick_sending`: how a tick is
  sent (staged moves and a broadcast START, or one move frame through a board);
- :mod:`~choreo.play.health`: the reads between ticks; :mod:`~choreo.play.realtime`: the
  player's priority;
- :mod:`~choreo.play.report`: what a play tells (progress, the report, its JSON document);
- :mod:`~choreo.play.dry_run`: the packets a play would send; :mod:`~choreo.play.robot_bus`: the
  robot's bus, else the built-in emulator;
- :mod:`~choreo.play.soundtrack`: the song beside the servos; :mod:`~choreo.play.path_errors`:
  how far the emulated servos strayed; :mod:`~choreo.play.recorder`: teaching by hand, live;
  :mod:`~choreo.play.recording`: what was taught, journaled, reduced and written as a motion.
"""
