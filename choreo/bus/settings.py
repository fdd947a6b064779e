"""How to talk to a robot's bus: port, timeout, retries, echo, direction lines (a robot file's
``bus:`` section, under the command line's options), and the ranges both accept. Light on
purpose: the bus-only commands read these defaults for their ``--help`` without numpy or a robot.
"""

from __future__ import annotations

from dataclasses import dataclass

from choreo.core.arguments import Range

# The ranges the command line, the robot file's ``bus:`` section and ServoBus all accept. A servo
# answers within milliseconds; a read waiting longer than MAX_TIMEOUT_MS is a dead link, not a
# slow one.
# Where no port is named: the built-in emulated bus, servos 1-6 (a caller that knows its robot
# passes the robot's servos instead: ServoBus.from_settings(settings, emulated=...)).
BUILT_IN_PORT = "sim://?ids=1-6"
MAX_RETRIES = 9
MAX_TIMEOUT_MS = 5000.0
TIMEOUT_S = Range(above=0, at_most=MAX_TIMEOUT_MS / 1000, unit=" s")
RETRIES = Range(at_least=0, at_most=MAX_RETRIES, whole=True)


@dataclass(frozen=True)
class BusSettings:
    port: str | None = None  # None: the built-in emulated bus (BUILT_IN_PORT)
    timeout_s: float = 0.05
    retries: int = 2
    echo: str = "auto"  # none | discard | auto
    supply_v: float | None = None  # servo supply voltage (preview); None: each model's rated one
    direction: str | None = None  # GPIO direction lines of a Pi/Jetson UART: preset or rx=N,tx=N
