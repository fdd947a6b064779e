"""choreo: jerk-limited, synchronized motion for Hiwonder/LewanSoul serial bus servos."""

from .errors import (
    BusError,
    BusTimeoutError,
    ChoreoError,
    PlanningError,
    PlaybackAborted,
    PortError,
    PreviewError,
    ProtocolError,
    ServoFault,
    SourceError,
    UnsupportedByTransport,
)

__all__ = [
    "BusError",
    "BusTimeoutError",
    "ChoreoError",
    "PlanningError",
    "PlaybackAborted",
    "PortError",
    "PreviewError",
    "ProtocolError",
    "ServoFault",
    "SourceError",
    "UnsupportedByTransport",
]
__version__ = "0.1.0"
