"""Measuring a robot's servos where they stand: ``choreo identify``.

- :mod:`~choreo.identify.identify`: :func:`identify`, the whole run for a robot on a bus;
- :mod:`~choreo.identify.moves`: each joint's test moves, and the held-out ones;
- :mod:`~choreo.identify.measure`: running them with reads as fast as the bus allows;
- :mod:`~choreo.identify.joint_model`: the servo on its joint, simulated for many candidates;
- :mod:`~choreo.identify.neighbours`: the joint's neighbours, yielding under it as servos do;
- :mod:`~choreo.identify.compiled`: numpy's clip and interp without their wrappers;
- :mod:`~choreo.identify.fit`: the fit (CMA-ES, :mod:`~choreo.identify.search`) and the
  validation on held-out moves.
"""

from __future__ import annotations

from choreo.identify.fit import Validation
from choreo.identify.identify import IdentifyReport, JointResult, Progress, identify

__all__ = ["IdentifyReport", "JointResult", "Progress", "Validation", "identify"]
