"""Play ticks on the servos: preflight, streaming on an absolute clock, health, stop.

Each tick k: at its deadline one broadcast MOVE_START makes every servo begin its staged move at
the same instant; right after, tick k+1 is staged (MOVE_TIME_WAIT_WRITE) on each servo whose
target changes. Deadlines are absolute from one start time, so nothing drifts. Spare bus time
before the next START goes to health reads (position, VIN, temperature, rotating over the
servos), each with a timeout that ends before that START. If the host falls a whole tick behind,
the servos are re-targeted to where the plan is now instead of replaying stale ticks.

Preflight refuses servos that MOVE_STOP could not stop (motor mode). Every exit path other than
completion stops the servos (broadcast MOVE_STOP); then they are left as configured: holding
(torque on), moved slowly to an exit pose, or unloaded.

Through a controller board that cannot stage (``bus.capabilities.staged_start`` false: the RRC
and LOBOT boards) each tick goes out at its deadline as one multi-servo move frame with the tick's
duration (a tick's moves share one duration); the board forwards it one servo at a time, so
the frame is sent early enough for those starts to be centred on the deadline, and the report
gives the first-to-last start skew. Preflight, health reads and the stop use only what the
transport offers (``capabilities``); preflight checks it cannot make are listed by
:func:`unchecked`.
"""

from __future__ import annotations

import contextlib
import enum
import gc
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from choreo.bus.protocol import BROADCAST_ID, BYTE_TIME_S, SPECS, Command, encode_request
from choreo.bus.servo_bus import Presence, ServoBus
from choreo.bus.servo_models import DEG_PER_UNIT, POSITION_RANGE_UNITS, servo_model
from choreo.bus.settings import TIMEOUT_S
from choreo.core.arguments import (
    COUNT,
    Range,
    check_callable,
    check_flag,
    check_member,
    check_number,
    check_optional_number,
    check_text,
    check_type,
    shown,
)
from choreo.core.clock import Clock, RealClock
from choreo.errors import (
    BusError,
    BusTimeoutError,
    ChoreoError,
    OptionError,
    PlaybackAborted,
    ProtocolError,
    ServoFault,
)
from choreo.motion.timing import SPEED
from choreo.plan.planner import APPROACH_LIMIT_SCALE, plan_approach
from choreo.plan.ticks import MOVE_BYTES, START_BYTES, TOLERANCE_DEG, Tick, compile_ticks
from choreo.play.realtime import NOT_ASKED, Scheduling, realtime_priority
from choreo.robot.types import Joint, Robot

log = logging.getLogger(__name__)

READ_BYTES = SPECS[Command.POS_READ].request_len + 3 + SPECS[Command.POS_READ].read_reply_len + 3


class ExitMode(enum.Enum):
    HOLD = "hold"  # stay where stopped, torque on
    POSE = "pose"  # move slowly to the exit pose
    UNLOAD = "unload"  # torque off (the robot may sag or fall)


class Outcome(enum.Enum):
    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C / SIGTERM
    ABORTED = "aborted"  # a health check failed


class Reading(enum.Enum):
    """A health read: its command and reply field."""

    POSITION = (Command.POS_READ, "pos_units")
    VIN = (Command.VIN_READ, "vin_mv")
    TEMPERATURE = (Command.TEMP_READ, "temp_c")


# The ranges PlayOptions accepts (the command line's flags too): each argument is checked when
# the options are made, so a bad one never waits for the play to start.
HEALTH_TIMEOUT_S = TIMEOUT_S  # a health read is one more read on the bus
AUDIO_LATENCY_S = Range(above=0, at_most=2.0, unit=" s")  # Bluetooth: 0.2-0.3 s; seconds: a mistake
LEAD_S = Range(at_least=0, at_most=5.0, unit=" s")  # play_motion adds the audio latency to it
START_GUARD_S = Range(at_least=0, at_most=0.1, unit=" s")  # ticks last tens of ms
POSITION_ERROR_DEG = Range(above=0, at_most=POSITION_RANGE_UNITS[1] * DEG_PER_UNIT, unit="°")
TEMP_MARGIN_C = Range(at_least=0, at_most=100, whole=True, unit=" °C")  # limits are 50-100 °C


@dataclass(frozen=True)
class PlayOptions:
    """How a motion is played; every argument is checked here (``OptionError`` naming it).
    ``exit_mode`` may be given by name (``"pose"``)."""

    exit_mode: ExitMode = ExitMode.HOLD
    exit_pose: str = "home"  # where ExitMode.POSE goes, slowly
    tolerance_deg: float = 0.5  # how far the ticks may stray from the smooth plan, up to 5°
    # how the motion is planned (play_motion): its speed, stretching keyframes the servos
    # cannot reach in time, and a number of times to play it instead of the file's repeat
    speed: float | None = None
    stretch: bool = False
    loop: int | None = None
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
        check_number("tolerance_deg", self.tolerance_deg, TOLERANCE_DEG)
        check_optional_number("speed", self.speed, SPEED)
        check_optional_number("loop", self.loop, COUNT)
        for flag in ("stretch", "allow_past_song", "audio"):
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


@dataclass(frozen=True)
class ServoLimits:
    """What preflight read from a servo: the bounds the health checks enforce."""

    min_vin_mv: int | None  # None: the transport cannot read it
    max_vin_mv: int | None
    max_temp_c: int | None


@dataclass
class ServoHealth:
    """Extremes of what the health reads saw on one servo (None: never read)."""

    joint: str
    servo_id: int
    temp_c_min: int | None = None
    temp_c_max: int | None = None
    vin_mv_min: int | None = None
    vin_mv_max: int | None = None
    position_error_deg_max: float | None = None
    reads: int = 0
    missed_reads: int = 0  # in a row, reset by an answer
    missed_total: int = 0  # in the whole play

    def record(self, name: str, value: float) -> None:
        low, high = getattr(self, f"{name}_min", None), getattr(self, f"{name}_max")
        if hasattr(self, f"{name}_min"):
            setattr(self, f"{name}_min", value if low is None else min(low, value))
        setattr(self, f"{name}_max", value if high is None else max(high, value))


@dataclass(frozen=True)
class Progress:
    time_s: float
    duration_s: float
    tick: int
    ticks: int
    bus_use: float
    stage: str = ""  # what is being played, in words (play_motion: approach, keyframe 3/12)


@dataclass(frozen=True)
class PlayReport:
    outcome: Outcome
    reason: str
    ticks_played: int
    ticks_total: int
    retargeted: int
    lateness_ms: tuple[float, ...]  # per START, against its deadline
    bytes_sent: int
    planned_s: float
    elapsed_s: float
    health: tuple[ServoHealth, ...]
    start_time_s: float  # clock time of the first START's deadline
    transport: str = "raw LX bus"
    start_skew_ms: float = 0.0  # first-to-last start of a tick's moves (a board forwarding them)
    # what play_motion adds: what was played where, and on an emulator what its wire shows
    motion: str = ""
    robot: str = ""
    port: str = ""
    emulated: bool = False
    measured_start_skew_ms: float | None = None
    path_errors_deg: tuple[float, ...] | None = None  # per joint, against the smooth plan
    exit_move: PlayReport | None = None  # the move to the exit pose, if one was made
    scheduling: Scheduling = NOT_ASKED  # the priority the play ran with

    @property
    def bus_use(self) -> float:
        return self.bytes_sent * BYTE_TIME_S / self.elapsed_s if self.elapsed_s > 0 else 0.0

    def lateness_percentile_ms(self, q: float) -> float:
        return float(np.percentile(self.lateness_ms, q)) if self.lateness_ms else 0.0

    @property
    def missed_reads(self) -> int:
        """Health reads that went unanswered or came back garbled, over every servo."""
        return sum(h.missed_total for h in self.health)

    @property
    def end_error_ms(self) -> float:
        return (self.elapsed_s - self.planned_s) * 1000


# --- preflight ---------------------------------------------------------------------------------
def preflight(bus: ServoBus, robot: Robot) -> tuple[tuple[float, ...], dict[str, ServoLimits]]:
    """Check that every servo answers and is fit to move; load torque.

    Returns the measured pose (degrees, joint order) and each joint's servo limits. Raises a
    ChoreoError listing every problem; nothing has moved then.
    """
    _check_bus_and_robot(bus, robot)
    presence = {j: bus.presence(j.servo_id, retries=2) for j in robot.joints}
    silent = [j for j, p in presence.items() if p is Presence.SILENT]
    garbled = [j for j, p in presence.items() if p is Presence.GARBLED]
    problems = []
    if silent:
        problems.append(f"{len(silent)} servo(s) did not answer: {_names(silent)}")
    if garbled:
        problems.append(
            f"{len(garbled)} servo(s) answered garbled, as when two servos share an "
            f"ID: {_names(garbled)}"
        )
    if problems:
        raise ChoreoError(
            "; ".join(problems) + "; check power and wiring, or run `choreo scan` "
            "to see which IDs answer"
        )
    pose, limits = [], {}
    found: dict[str, list[Joint]] = {}  # a problem -> the joints that have it, in order
    for joint in robot.joints:
        position, servo_limits, joint_problems = _inspect(bus, joint)
        pose.append(joint.to_deg(position))
        limits[joint.name] = servo_limits
        who = f"{_names([joint])}: "
        for problem in joint_problems:
            found.setdefault(problem.removeprefix(who), []).append(joint)
    if found:
        lines = [f"{_names(joints)}: {problem}" for problem, joints in found.items()]
        raise ChoreoError("refusing to play:\n  " + "\n  ".join(lines))
    if bus.capabilities.load:  # else the approach's first move powers the servos
        for joint in robot.joints:
            bus.load(joint.servo_id)
    return tuple(pose), limits


def _check_bus_and_robot(bus: object, robot: object) -> None:
    check_type("bus", bus, ServoBus, "an open ServoBus: ServoBus(port)")
    check_type("robot", robot, Robot, "a Robot (load_robot, or a motion's .robot)")


def _check_player(bus, robot, clock, limits, options, on_progress) -> None:
    """Refuse what a Player cannot play with (``OptionError`` naming the argument)."""
    _check_bus_and_robot(bus, robot)
    if not all(callable(getattr(clock, name, None)) for name in ("now", "sleep_until")):
        raise OptionError(
            "clock", f"must be a clock (bus.clock, RealClock(), VirtualClock()), got {shown(clock)}"
        )
    if not isinstance(limits, dict):
        raise OptionError(
            "limits",
            f"must be each joint's ServoLimits by name, as preflight returns them, got "
            f"{shown(limits)}",
        )
    missing = [j.name for j in robot.joints if j.name not in limits]
    if missing:
        raise OptionError(
            "limits", f"has none for {', '.join(missing)}: pass what preflight returns"
        )
    check_type("options", options, PlayOptions, "a PlayOptions: PlayOptions(speed=2)")
    check_callable("on_progress", on_progress, optional=True)


PREFLIGHT_READS = {
    Command.VIN_READ: "supply voltage",
    Command.VIN_LIMIT_READ: "voltage limits",
    Command.TEMP_READ: "temperature",
    Command.TEMP_MAX_LIMIT_READ: "temperature limit",
    Command.ANGLE_LIMIT_READ: "angle limits",
    Command.OR_MOTOR_MODE_READ: "motor mode",
}


def unchecked(bus: ServoBus) -> list[str]:
    """What preflight and the health reads cannot check through this transport."""
    return [
        what for command, what in PREFLIGHT_READS.items() if not bus.capabilities.supports(command)
    ]


def _names(joints: Sequence[Joint]) -> str:
    return ", ".join(f"{j.name} (ID {j.servo_id})" for j in joints)


def _inspect(bus: ServoBus, joint: Joint) -> tuple[int, ServoLimits, list[str]]:
    sid, who = joint.servo_id, f"{joint.name} (ID {joint.servo_id})"

    def read(command: Command, reader):
        return reader(sid) if bus.capabilities.supports(command) else None

    position = bus.read_position(sid)
    vin, vin_limits = (
        read(Command.VIN_READ, bus.read_vin),
        read(Command.VIN_LIMIT_READ, bus.read_vin_limits),
    )
    temp = read(Command.TEMP_READ, bus.read_temperature)
    temp_limit = read(Command.TEMP_MAX_LIMIT_READ, bus.read_temp_limit)
    angle_limits = read(Command.ANGLE_LIMIT_READ, bus.read_angle_limits)
    mode = read(Command.OR_MOTOR_MODE_READ, bus.read_mode)
    problems = []
    if mode is not None and mode.motor:
        problems.append(
            f"{who}: is in motor mode (turning at duty {mode.speed}), which MOVE_STOP "
            "cannot stop; stop its motor first (choreo.bus.servo_config.stop_motor)"
        )
    if (
        vin is not None
        and vin_limits is not None
        and not vin_limits.min_mv <= vin <= vin_limits.max_mv
    ):
        problems.append(
            f"{who}: supply {vin} mV is outside the servo's limits "
            f"{vin_limits.min_mv}..{vin_limits.max_mv} mV; check the power supply"
        )
    if vin is not None:
        problems += _model_supply_problems(joint, vin)
    if temp is not None and temp_limit is not None and temp >= temp_limit:
        problems.append(
            f"{who}: {temp} °C is at or above the servo's limit {temp_limit} °C; let it cool down"
        )
    low, high = joint.limits_units
    if angle_limits is not None and (
        angle_limits.min_units > round(low) or angle_limits.max_units < round(high)
    ):
        problems.append(
            f"{who}: the servo's own angle limits "
            f"{angle_limits.min_units}..{angle_limits.max_units}"
            f" are narrower than the robot file's {round(low)}..{round(high)} units "
            f"({joint.limits.min_deg:g}..{joint.limits.max_deg:g}°); widen them with "
            "`choreo servo limits` or narrow the joint limits in the robot file"
        )
    vin_low, vin_high = (vin_limits.min_mv, vin_limits.max_mv) if vin_limits else (None, None)
    return position, ServoLimits(vin_low, vin_high, temp_limit), problems


def _model_supply_problems(joint: Joint, vin_mv: int) -> list[str]:
    """The supply against the rated range of the model the robot file names (the limits stored
    in the servo are often the protocol's 4.5-14 V, which lets an LX-16A run on 11 V)."""
    model = servo_model(joint.servo_model)
    low, high = model.vin_range_mv
    if low <= vin_mv <= high:
        return []
    return [
        f"{joint.name} (ID {joint.servo_id}): supply {vin_mv / 1000:.1f} V is outside the "
        f"{model.name}'s rated {low / 1000:g}-{high / 1000:g} V (the robot file's servo model); "
        "check the power supply, or the joint's servo model in the robot file"
    ]


# --- the packets of a tick ---------------------------------------------------------------------
def staged_moves(tick: Tick, robot: Robot, *, all_servos: bool = False):
    """(joint, pos_units, time_ms) for each servo that must be staged for ``tick``."""
    for joint, target, staged in zip(robot.joints, tick.targets_units, tick.staged):
        if staged or all_servos:
            yield joint, target, tick.duration_ms


@dataclass(frozen=True)
class ScheduledPacket:
    time_ms: int  # when it is sent, from the first START
    packet: bytes
    description: str


def packet_schedule(ticks: Sequence[Tick], robot: Robot) -> list[ScheduledPacket]:
    """Every packet the player sends for ``ticks`` (without health reads), in order: the dry run."""
    schedule = []

    def stage(tick: Tick, at_ms: int, all_servos: bool) -> None:
        for joint, pos, time_ms in staged_moves(tick, robot, all_servos=all_servos):
            packet = encode_request(
                Command.MOVE_TIME_WAIT_WRITE, joint.servo_id, pos_units=pos, time_ms=time_ms
            )
            schedule.append(
                ScheduledPacket(at_ms, packet, f"stage {joint.name} -> {pos} in {time_ms} ms")
            )

    if ticks:
        stage(ticks[0], ticks[0].start_ms, all_servos=True)
    for k, tick in enumerate(ticks):
        if k == 0 or any(tick.staged):  # a tick that changes no target needs no START
            schedule.append(
                ScheduledPacket(
                    tick.start_ms,
                    encode_request(Command.MOVE_START, BROADCAST_ID),
                    f"START tick {k} ({tick.duration_ms} ms)",
                )
            )
        if k + 1 < len(ticks):
            stage(ticks[k + 1], tick.start_ms, all_servos=False)
    return schedule


def frame_schedule(ticks: Sequence[Tick], robot: Robot, move_frame) -> list[ScheduledPacket]:
    """The dry run through a board that cannot stage: one move frame per tick that changes a
    target, built by the board's ``move_frame(moves, time_ms)``, at the tick's start."""
    schedule = []
    for k, tick in enumerate(ticks):
        moves = [(j.servo_id, pos) for j, pos, _ in staged_moves(tick, robot, all_servos=k == 0)]
        if moves:
            schedule.append(
                ScheduledPacket(
                    tick.start_ms,
                    move_frame(moves, tick.duration_ms),
                    f"tick {k}: move {len(moves)} servo(s) in {tick.duration_ms} ms",
                )
            )
    return schedule


# --- playing -----------------------------------------------------------------------------------
class Player:
    """Streams ticks to the servos of ``robot`` on ``bus`` with deadlines from ``clock``."""

    def __init__(
        self,
        bus: ServoBus,
        robot: Robot,
        clock: Clock,
        limits: dict[str, ServoLimits],
        options: PlayOptions = PlayOptions(),
        on_progress: Callable[[Progress], None] | None = None,
    ):
        _check_player(bus, robot, clock, limits, options, on_progress)
        self.bus, self.robot, self.clock, self.options = bus, robot, clock, options
        self.limits = limits
        self.on_progress = on_progress
        # Called once per play with the clock time of the first START, before anything is sent
        # (the song is cued on it: choreo/play/soundtrack.py).
        self.on_first_start: Callable[[float], None] | None = None
        # Called once per play with the priority it got, before anything is sent.
        self.on_scheduling: Callable[[Scheduling], None] | None = None
        self.health = tuple(ServoHealth(j.name, j.servo_id) for j in robot.joints)
        # Positions are checked most often; each round also reads one servo's VIN and temperature.
        n = len(robot.joints)
        readable = bus.capabilities.supports
        self._rotation = [
            item
            for c in range(n)
            for item in [(i, Reading.POSITION) for i in range(n)]
            + [(c, Reading.VIN), (c, Reading.TEMPERATURE)]
            if readable(item[1].value[0])
        ]
        self._next_read = 0
        self._suspect: int | None = None  # a joint whose last read went unanswered: read it next

    def play(
        self,
        ticks: Sequence[Tick],
        start_pose_deg: Sequence[float],
        start_at_s: float | None = None,
    ) -> PlayReport:
        """Play ``ticks`` from ``start_pose_deg`` (where the servos are now): the first START as
        soon as tick 0 is staged, or at ``start_at_s`` on the clock (a show's instant: if that
        is already past, the servos are re-targeted to where the plan is by then)."""
        # The priority first: locking the memory takes a while, before the deadlines are set.
        with self._priority() as scheduling:
            if self.on_scheduling:
                self.on_scheduling(scheduling)
            return self._play(list(ticks), start_pose_deg, scheduling, start_at_s)

    def _play(
        self,
        ticks: list[Tick],
        start_pose_deg: Sequence[float],
        scheduling: Scheduling,
        start_at_s: float | None,
    ) -> PlayReport:
        stream = _Stream(self, ticks, start_pose_deg, start_at_s)
        stream.scheduling = scheduling
        collecting = gc.isenabled()
        gc.disable()  # a full collection can pause for tens of ms; streaming makes no cycles
        try:
            stream.run()
        except KeyboardInterrupt:
            self.stop()
            stream.finish(Outcome.INTERRUPTED, "interrupted")
        except (PlaybackAborted, ServoFault) as error:
            self.stop()
            stream.finish(Outcome.ABORTED, str(error))
        except BaseException:
            self.stop()
            raise
        finally:
            if collecting:
                gc.enable()
        return stream.report()

    def _priority(self) -> contextlib.AbstractContextManager[Scheduling]:
        wanted = self.options.realtime
        if wanted is None:
            wanted = isinstance(self.clock, RealClock)
        return realtime_priority() if wanted else contextlib.nullcontext(NOT_ASKED)

    def stop(self) -> None:
        """Stop every servo by the transport's best means (``capabilities.stop``: a broadcast
        MOVE_STOP on the raw bus).

        Moves still waiting in the output buffer are dropped so the stop goes out first.
        """
        try:
            self.bus.discard_output()
            self.bus.stop_servos([j.servo_id for j in self.robot.joints])
            self.bus.drain()
        except (BusError, OSError) as error:  # the port itself may be gone
            log.error("could not send MOVE_STOP: %s", error)

    def leave(self, outcome: Outcome) -> PlayReport | None:
        """Leave the servos as configured: holding (nothing to do), at the exit pose, unloaded.
        Returns the report of the move to the exit pose, if one was made.

        After an abort the robot is not moved again: a lost or hot servo must not be driven.
        """
        mode, exit_move = self.options.exit_mode, None
        if mode is ExitMode.POSE and outcome is not Outcome.ABORTED:
            exit_move = go_to_pose(self, self.options.exit_pose)
        elif mode is ExitMode.UNLOAD:
            for joint in self.robot.joints:
                self.bus.unload(joint.servo_id)
        self.bus.drain()  # the port may close next: let the last commands out first
        return exit_move

    # --- health --------------------------------------------------------------------------------
    def read_health(self, budget_s: float, expected_units: np.ndarray) -> bool:
        """One health read if it fits in ``budget_s``; whether it was made."""
        timeout_s = self.options.health_timeout_s
        if budget_s < timeout_s + self.options.start_guard_s:
            return False
        index, reading = self._pick_read()
        joint, health = self.robot.joints[index], self.health[index]
        command, name = reading.value
        try:
            value = self.bus.request(command, joint.servo_id, retries=0, timeout_s=timeout_s)[name]
        except (BusTimeoutError, ProtocolError) as error:  # one bad read is noise; a run is not
            health.missed_reads += 1
            health.missed_total += 1
            self._suspect = index
            log.info("health read of %s missed: %s", joint.name, error)
            if health.missed_reads >= self.options.max_missed_reads:
                raise PlaybackAborted.naming(
                    "health_timeout_s",
                    f"{joint.name} (ID {joint.servo_id}) stopped answering "
                    f"({health.missed_reads} reads in a row timed out or came "
                    "back garbled); check its cable, or allow a slow USB "
                    "adapter more time ({option})",
                ) from None
            return True
        health.missed_reads = 0
        health.reads += 1
        self._suspect = None
        self._check(index, reading, value, expected_units[index])
        return True

    def _pick_read(self) -> tuple[int, Reading]:
        if self._suspect is not None:
            return self._suspect, Reading.POSITION
        item = self._rotation[self._next_read % len(self._rotation)]
        self._next_read += 1
        return item

    def _check(self, index: int, reading: Reading, value: int, expected_units: float) -> None:
        joint, health = self.robot.joints[index], self.health[index]
        limits = self.limits[joint.name]
        who = f"{joint.name} (ID {joint.servo_id})"
        if reading is Reading.TEMPERATURE:
            health.record("temp_c", value)
            if limits.max_temp_c is not None and (
                value >= limits.max_temp_c - self.options.temp_margin_c
            ):
                raise ServoFault(
                    f"{who} is at {value} °C, near its limit {limits.max_temp_c} °C",
                    servo_id=joint.servo_id,
                    command=Command.TEMP_READ,
                )
        elif reading is Reading.VIN:
            health.record("vin_mv", value)
            low, high = limits.min_vin_mv, limits.max_vin_mv
            if low is not None and high is not None and not low <= value <= high:
                raise ServoFault(
                    f"{who} supply is {value} mV, outside "
                    f"{limits.min_vin_mv}..{limits.max_vin_mv} mV",
                    servo_id=joint.servo_id,
                    command=Command.VIN_READ,
                )
        else:
            error_deg = abs(joint.to_deg(value) - joint.to_deg(expected_units))
            health.record("position_error_deg", error_deg)
            if error_deg > self.options.max_position_error_deg:
                raise PlaybackAborted(
                    f"{who} is {error_deg:.1f}° away from where it should be "
                    f"(limit {self.options.max_position_error_deg:g}°): blocked or overloaded?"
                )


class _Stream:
    """The state of one pass over a tick list."""

    def __init__(
        self,
        player: Player,
        ticks: list[Tick],
        start_pose_deg: Sequence[float],
        start_at_s: float | None = None,
    ):
        self.player = player
        self.ticks = ticks
        self.previous_units = player.robot.to_units(start_pose_deg)
        self.current_units = self.previous_units.copy()
        self.lateness_ms: list[float] = []
        self.retargeted = 0
        self.bytes_sent = 0
        self.wire_free_s = -np.inf  # when the bytes sent so far will have left the host
        self.capabilities = player.bus.capabilities
        self.staging = self.capabilities.staged_start  # else one move frame per tick
        self.most_moved = 0  # servos in the largest move frame (for the start skew)
        self.scheduling = NOT_ASKED  # set by Player.play
        self.played = 0
        self.outcome, self.reason = Outcome.COMPLETED, ""
        # Start once whatever was sent before has left and every servo of tick 0 is staged
        # (through a board: once tick 0's move frame can reach its servos on time).
        player.bus.drain()
        n = len(player.robot.joints)
        if self.staging:
            first_s = n * MOVE_BYTES * BYTE_TIME_S
        else:
            first_s = self.frame_lead_s(n) + self.capabilities.start_skew_s(n) / 2
        self.t0 = player.clock.now() + first_s + player.options.lead_s
        if start_at_s is not None:
            self.t0 = start_at_s
        self.end_s = self.t0

    @property
    def planned_s(self) -> float:
        last = self.ticks[-1] if self.ticks else None
        return (last.start_ms + last.duration_ms) / 1000 if last else 0.0

    def deadline(self, k: int) -> float:
        return self.t0 + self.ticks[k].start_ms / 1000

    def run(self) -> None:
        if not self.ticks:
            return
        if self.player.on_first_start is not None:
            self.player.on_first_start(self.t0)
        self.stage(self.ticks[0], all_servos=True)
        k = 0
        while k < len(self.ticks):
            k = self.catch_up(k)
            self.start(k)
            if k + 1 < len(self.ticks):
                self.stage(self.ticks[k + 1], all_servos=False)
                self.use_spare_time(k)
            k += 1
        self.player.clock.sleep_until(self.t0 + self.planned_s)
        self.end_s = self.player.clock.now()

    def catch_up(self, k: int) -> int:
        """If tick k's time is already over, jump to the tick the plan will be in once every
        servo is re-staged (and the servos' start gap has passed), shortened to end on time.
        Through a board, a link still busy with earlier frames counts as behind too."""
        clock, ticks = self.player.clock, self.ticks
        now = clock.now() if self.staging else max(clock.now(), self.wire_free_s)
        if k + 1 >= len(ticks) or now < self.deadline(k + 1):
            return k
        restage_s = (
            len(self.player.robot.joints) * MOVE_BYTES * BYTE_TIME_S
            if self.staging
            else self.frame_lead_s(len(self.player.robot.joints))
        )
        ready_ms = math.ceil((now + restage_s + self.player.options.start_guard_s - self.t0) * 1000)
        j = k + 1
        while j + 1 < len(ticks) and ready_ms >= ticks[j + 1].start_ms:
            j += 1
        log.warning(
            "fell behind by %.1f ms: re-targeting from tick %d to tick %d",
            (now - self.deadline(k)) * 1000,
            k,
            j,
        )
        self.retargeted += 1
        start_ms = min(ready_ms, ticks[j].end_ms - 1)
        ticks[j] = replace(
            ticks[j],
            start_ms=start_ms,
            duration_ms=ticks[j].end_ms - start_ms,
            staged=(True,) * len(ticks[j].staged),
        )  # re-staged: needs its START
        self.stage(ticks[j], all_servos=True)
        return j

    def start(self, k: int) -> None:
        """START tick k so that it arrives at the servos on its deadline.

        A tick that changes no target sends nothing: every servo is already there.
        """
        clock, tick = self.player.clock, self.ticks[k]
        moves = [
            (joint.servo_id, pos)
            for joint, pos, _ in staged_moves(tick, self.player.robot, all_servos=k == 0)
        ]
        if self.staging:
            lead_s = START_BYTES * BYTE_TIME_S
        else:  # the board's one-servo-at-a-time starts are centred on the deadline
            lead_s = self.frame_lead_s(len(moves)) + self.capabilities.start_skew_s(len(moves)) / 2
        send_at = self.deadline(k) - lead_s
        clock.sleep_until(send_at)  # also for a tick without START: what follows is timed from it
        if moves:
            # through a board, the frame leaves once the link is free of the frames before it
            leaves_s = clock.now() if self.staging else max(clock.now(), self.wire_free_s)
            self.lateness_ms.append((leaves_s - send_at) * 1000)
            if self.staging:
                self.player.bus.start(BROADCAST_ID)
                self.sent(START_BYTES)
            else:
                sent = self.player.bus.move_many(moves, tick.duration_ms)
                self.most_moved = max(self.most_moved, len(moves))
                self.sent(sent, busy_s=self.frame_busy_s(sent, len(moves)))
        self.previous_units = self.current_units
        self.current_units = np.asarray(self.ticks[k].targets_units, dtype=float)
        self.played = k + 1
        self.report_progress(k)

    def frame_lead_s(self, servos: int) -> float:
        """From sending a board's move frame until its first servo starts moving."""
        cap = self.capabilities
        frame_bytes = cap.move_frame_bytes + 3 * servos
        return frame_bytes * cap.host_byte_time_s + cap.forward_s_per_servo

    def frame_busy_s(self, frame_bytes: int, servos: int) -> float:
        """How long a move frame keeps the board's link and servo bus busy."""
        cap = self.capabilities
        return frame_bytes * cap.host_byte_time_s + servos * cap.forward_s_per_servo

    def stage(self, tick: Tick, *, all_servos: bool) -> None:
        if not self.staging:
            return  # the move frame at the tick's deadline carries its targets
        bus = self.player.bus
        for joint, pos, time_ms in staged_moves(tick, self.player.robot, all_servos=all_servos):
            bus.stage_move(joint.servo_id, pos, time_ms)
            self.sent(MOVE_BYTES)

    def use_spare_time(self, k: int) -> None:
        """Health reads until the next START's guard time (never delaying it)."""
        clock, next_start = self.player.clock, self.deadline(k + 1)
        tick = self.ticks[k]
        # A board's link carries the read's request and reply too (~16 bytes; 17 ms at 9600 baud).
        link_s = 0.0 if self.staging else 16 * self.capabilities.host_byte_time_s
        for _ in range(len(self.player.robot.joints)):  # bounded: at most one round per tick
            now = clock.now()
            budget = next_start - max(now, self.wire_free_s) - link_s
            fraction = np.clip((now - self.deadline(k)) / (tick.duration_ms / 1000), 0.0, 1.0)
            expected = self.previous_units + fraction * (self.current_units - self.previous_units)
            if not self.player.read_health(budget, expected):
                return
            self.sent(READ_BYTES)

    def sent(self, count: int, busy_s: float | None = None) -> None:
        """Account for bytes put on the wire: it sends them one after another at 115200 baud
        (``busy_s``: how long they keep a board busy instead)."""
        now = self.player.clock.now()
        busy_s = count * BYTE_TIME_S if busy_s is None else busy_s
        self.wire_free_s = max(now, self.wire_free_s) + busy_s
        self.bytes_sent += count

    def report_progress(self, k: int) -> None:
        if self.player.on_progress:
            now = self.player.clock.now() - self.t0
            self.player.on_progress(
                Progress(
                    now,
                    self.planned_s,
                    k + 1,
                    len(self.ticks),
                    self.bytes_sent * BYTE_TIME_S / max(now, 1e-3),
                )
            )

    def finish(self, outcome: Outcome, reason: str) -> None:
        self.outcome, self.reason = outcome, reason
        self.end_s = self.player.clock.now()

    def report(self) -> PlayReport:
        return PlayReport(
            outcome=self.outcome,
            reason=self.reason,
            ticks_played=self.played,
            ticks_total=len(self.ticks),
            retargeted=self.retargeted,
            lateness_ms=tuple(self.lateness_ms),
            bytes_sent=self.bytes_sent,
            planned_s=self.planned_s,
            elapsed_s=self.end_s - self.t0,
            health=self.player.health,
            start_time_s=self.t0,
            transport=self.capabilities.transport,
            start_skew_ms=self.capabilities.start_skew_s(self.most_moved) * 1000,
            scheduling=self.scheduling,
        )


def go_to_pose(player: Player, pose: str) -> PlayReport:
    """Move slowly from wherever the servos are to a named pose of the robot (the exit pose),
    with health records of its own."""
    robot, options = player.robot, player.options
    start = [j.to_deg(player.bus.read_position(j.servo_id)) for j in robot.joints]
    trajectory = plan_approach(robot, start, robot.pose_vector(pose), APPROACH_LIMIT_SCALE)
    mover = Player(player.bus, robot, player.clock, player.limits, options)
    return mover.play(
        compile_ticks(trajectory, robot, tolerance_deg=options.tolerance_deg).ticks, start
    )
