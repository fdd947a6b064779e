"""What every other part of choreo builds on: clocks, files written whole, YAML read with the
line and column of every value, and the shapes the JSON Schemas give the files.

- :mod:`~choreo.core.clock`: :class:`RealClock` and :class:`VirtualClock` (tests, previews);
- :mod:`~choreo.core.atomic`: a file is replaced whole or not at all;
- :mod:`~choreo.core.yaml_source`: YAML with source locations, for file:line messages;
- :mod:`~choreo.core.file_shape`: the keys each file kind may have, read from its schema.
"""

from __future__ import annotations

from choreo.core.clock import Clock, RealClock, VirtualClock

__all__ = ["Clock", "RealClock", "VirtualClock"]
