"""The world behind the emulated servos when it is the physics (``sim://?physics=ROBOT``).

An emulated servo on its own moves its horn exactly as it plans to. With a physical world behind
it, its plan is only its set-point: the world (the robot's MuJoCo model driven by the preview's
servo law, ``choreo.preview.twin``) says where the loaded horn really is, what the supply sags to
and how warm the servo gets, and the servo reads and reports that.

The emulator knows servos and wires, not robots: it finds the world by its module's name when a
URL asks for it (:data:`PROVIDER`), as the bus finds the emulator through its ``sim`` entry point,
so nothing here imports the layers above.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from choreo.core.clock import Clock

PROVIDER = "choreo.preview.twin"  # the module whose physics_for() builds the world


class SetPoint(Protocol):
    """Where a servo's own interpolation puts its horn: uniform motion from ``start_s`` (at
    ``start_units``) until ``end_s``, in output units (no EEPROM offset)."""

    @property
    def start_s(self) -> float: ...
    @property
    def start_units(self) -> float: ...
    @property
    def velocity_units_s(self) -> float: ...
    @property
    def end_s(self) -> float: ...


class ServoPhysics(Protocol):
    """One servo's horn in the world. Times are the bus clock's; positions in output units."""

    def drive(self, time_s: float, setpoint: SetPoint, loaded: bool) -> None:
        """From ``time_s`` on the servo aims along ``setpoint`` (pushing only if ``loaded``)."""

    def output_units(self, time_s: float) -> float:
        """Where the horn really is at ``time_s``."""

    def vin_mv(self, time_s: float) -> int:
        """The supply at the servo at ``time_s``."""

    def temp_c(self, time_s: float) -> float:
        """The servo's temperature at ``time_s``."""


@dataclass(frozen=True)
class PhysicalServo:
    """A servo the world puts on the bus: its ID, model and where its horn stands at first,
    and the speed its own moves are capped at (None: its model's datasheet speed). The world's
    servo may be faster or slower than the datasheet's (a truth file says), and its moves are
    capped at its own speed, as the preview's servos cap theirs."""

    servo_id: int
    model: str
    position_units: float
    physics: ServoPhysics
    top_speed_deg_s: float | None = None


class Physics(Protocol):
    """The world: the servos it drives, in the robot's joint order."""

    @property
    def servos(self) -> Sequence[PhysicalServo]: ...


def load_physics(robot: str, truth: str | None, clock: Clock, *, stand: bool = False) -> Physics:
    """The world of ``robot`` (a name or a robot file) with the servos of ``truth`` (a truth
    file, None: the robot file's figures), on ``clock``; ``stand``: a free-floating robot held
    in the air. ``ChoreoError`` or ``ValueError`` naming what is wrong."""
    provider = importlib.import_module(PROVIDER)
    return provider.physics_for(robot, truth, clock, stand=stand)  # type: ignore[no-any-return]
