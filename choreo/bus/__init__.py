"""The servo bus: the LX protocol, :class:`ServoBus` over any transport, finding ports, the servo
models' datasheet facts and their configuration.

- :mod:`~choreo.bus.protocol`: the LX packet codec (commands, fields and their ranges);
- :mod:`~choreo.bus.framing`: the resync core every frame decoder shares (LX, RRC, LOBOT);
- :mod:`~choreo.bus.servo_bus`: :class:`ServoBus`, the one place commands are sent and read;
  :mod:`~choreo.bus.typed_commands` its typed commands and what they read, and
  :mod:`~choreo.bus.read_failure` why a read got no valid reply;
- :mod:`~choreo.bus.settings`: how to reach a robot's bus (:class:`BusSettings`), the built-in
  emulated bus where no port is named;
- :mod:`~choreo.bus.transports`: the backends a port string picks (raw LX, ``rrc://``,
  ``lobot://``, and those packages add: the emulator's ``sim://``), each keeping one contract
  (``Transport``) and declaring its :class:`Capabilities`;
- :mod:`~choreo.bus.ports`: which port is which (``choreo ports``);
- :mod:`~choreo.bus.servo_models`: the datasheet table (LX-16A, LX-224HV ...);
- :mod:`~choreo.bus.servo_config`: reading and changing what a servo keeps (``choreo servo``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from choreo.bus.protocol import Command

# The bus and its transports (pyserial) are imported on first use: the planner reads the codec
# and the datasheet table from here without them.
_MODULE_OF = {"Capabilities": "choreo.bus.transports", "ServoBus": "choreo.bus.servo_bus"}
__all__ = ["Capabilities", "Command", "ServoBus"]


def __getattr__(name: str) -> object:
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'choreo.bus' has no attribute {name!r}")
    return getattr(importlib.import_module(_MODULE_OF[name]), name)


if TYPE_CHECKING:
    from choreo.bus.servo_bus import ServoBus
    from choreo.bus.transports import Capabilities
