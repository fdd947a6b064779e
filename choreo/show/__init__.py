"""Shows: several robots, each with its own computer and bus, dancing together.

Built on Zenoh (the ``choreo[show]`` extra, imported only in :mod:`choreo.show.network`): every
``choreo perform`` announces itself with a liveliness token and serves its part of the protocol
as queryables; ``choreo show`` (the conductor) finds them, measures their clocks, stages each
part, and tells every performer the one wall-clock instant its part starts. Losing the other side
(its liveliness token disappears) stops the servos.
"""
