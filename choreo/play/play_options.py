"""How a motion is played (``PlayOptions``): how it is planned (``PlanOptions``), danced
(``loop``, its song), streamed (lead, health reads, limits) and left (``ExitMode``).

Each argument is checked when the options are made (``OptionError`` naming it), against the same
ranges the command line parses its flags with, so a bad one never waits for the play to start.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from choreo.bus.servo_models import DEG_PER_UNIT, POSITION_RANGE_UNITS
from choreo.bus.settings import TIMEOUT_S
from choreo.core.arguments import (
    COUNT,
    Range,
    check_flag,
    check_member,
    check_number,
    check_optional_number,
    check_text,
)
from choreo.plan.pipeline import PlanOptions

_PLAN = PlanOptions()  # whose defaults PlayOptions' own planning fields take


class ExitMode(enum.Enum):
    HOLD = "hold"  # stay where stopped, torque on
    POSE = "pose"  # move slowly to the exit pose
    UNLOAD = "unload"  # torque off (the robot may sag or fall)


HEALTH_TIMEOUT_S = TIMEOUT_S  # a health read is one more read on the bus
AUDIO_LATENCY_S = Range(above=0, at_most=2.0, unit=" s")  # Bluetooth: 0.2-0.3 s; seconds: a mistake
LEAD_S = Range(at_least=0, at_most=5.0, unit=" s")  # play_motion adds the audio latency to it
START_GUARD_S = Range(at_least=0, at_most=0.1, unit=" s")  # ticks last tens of ms
POSITION_ERROR_DEG = Range(above=0, at_most=POSITION_RANGE_UNITS[1] * DEG_PER_UNIT, unit="°")
TEMP_MARGIN_C = Range(at_least=0, at_most=100, whole=True, unit=" °C")  # limits are 50-100 °C


@dataclass(frozen=True)
class PlayOptions:
    """How a motion is played; every argument is checked here (``OptionError`` naming it).
    ``exit_mode`` may be given by name (``"pose"``). ``speed``, ``stretch`` and
    ``tolerance_deg`` are how it is planned: :attr:`plan` gives them as the planner takes them."""

    exit_mode: ExitMode = ExitMode.HOLD
    exit_pose: str = "home"  # where ExitMode.POSE goes, slowly
    tolerance_deg: float = _PLAN.tolerance_deg  # how far the ticks may stray from the plan
    speed: float | None = _PLAN.speed  # None: the file's speed
    stretch: bool = _PLAN.stretch  # move keyframes the servos cannot reach in time later
    loop: int | None = None  # times to play it, instead of the file's repeat
    allow_past_song: bool = False  # a dance may outlast its song (warned, not refused)
    # the song of a motion with a music: block (play_motion)
    audio: bool = True
    audio_device: str | None = None  # None: the system's output
    audio_latency_s: float | None = None  # None: what the device reports; else up to 2 s
    lead_s: float = 0.01  # spare time between staging the first tick and its START
    health_timeout_s: float = 0.02  # per health read, up to 5 s; reads happen only when they fit
    start_guard_s: float = 0.002  # bus time kept free before every START
    max_missed_reads: int = 3  # consecutive unanswered reads before a servo counts as lost
    max_position_error_deg: float = 15.0
    temp_margin_c: int = 5  # abort this far below the servo's own temperature limit
    # SCHED_FIFO + locked memory for the play where permitted (choreo/play/realtime.py); None: only
    # with a real clock (a virtual one needs no priority)
    realtime: bool | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "exit_mode", check_member("exit_mode", self.exit_mode, ExitMode))
        check_text("exit_pose", self.exit_pose)
        _ = self.plan  # PlanOptions checks speed, stretch and tolerance_deg
        check_optional_number("loop", self.loop, COUNT)
        for flag in ("allow_past_song", "audio"):
            check_flag(flag, getattr(self, flag))
        check_text("audio_device", self.audio_device, optional=True)
        check_optional_number("audio_latency_s", self.audio_latency_s, AUDIO_LATENCY_S)
        check_number("lead_s", self.lead_s, LEAD_S)
        check_number("health_timeout_s", self.health_timeout_s, HEALTH_TIMEOUT_S)
        check_number("start_guard_s", self.start_guard_s, START_GUARD_S)
        check_number("max_missed_reads", self.max_missed_reads, COUNT)
        check_number("max_position_error_deg", self.max_position_error_deg, POSITION_ERROR_DEG)
        check_number("temp_margin_c", self.temp_margin_c, TEMP_MARGIN_C)
        if self.realtime is not None:
            check_flag("realtime", self.realtime)

    @property
    def plan(self) -> PlanOptions:
        """How the motion is planned: ``speed``, ``stretch`` and ``tolerance_deg``."""
        return PlanOptions(self.speed, self.stretch, self.tolerance_deg)
