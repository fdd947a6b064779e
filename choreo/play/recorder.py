"""Teach by hand, the live side: pose the robot with its servos unloaded and capture poses.

A :class:`Recorder` unloads the taught joints (the others hold), turns the lines the user types
into captures and undos, and loads the taught joints again when it ends, whatever the way out
(unless told to leave them unloaded). It reads lines from any iterable or callable and times
captures with any clock, so tests drive it in virtual time; it prints nothing, but reports what
happened as events. What it captures goes into a :class:`~choreo.play.recording.Recording`,
which journals it and writes the motion file.

A capture reads every joint (degrees via ``Joint.to_deg``); one outside a joint's limits is
refused, never clamped. ``after`` is the time since the previous capture.
"""

from __future__ import annotations

import enum
import functools
import logging
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from choreo.bus import servo_config
from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import Clock
from choreo.core.yaml_source import did_you_mean
from choreo.errors import BusError, OptionError, UnsupportedByTransport
from choreo.play.recording import ANGLE_DECIMALS, Capture, Recording
from choreo.robot.types import Joint, Robot

log = logging.getLogger(__name__)

INPUT_POLL_S = 0.1  # how soon q or Enter ends a slowly sampled stream

LineSource = Iterable["str | None"] | Callable[[], "str | None"]


# --- events: what the recorder reports (the CLI prints them) ------------------------------------
@dataclass(frozen=True)
class Captured:
    number: int  # 1 = the first capture of the recording
    capture: Capture


@dataclass(frozen=True)
class Refused:
    problems: tuple[str, ...]  # one per joint outside its limits


@dataclass(frozen=True)
class Undone:
    number: int  # the capture removed
    remaining: int


@dataclass(frozen=True)
class NothingToUndo:
    pass


@dataclass(frozen=True)
class UnknownInput:
    text: str


Event = Captured | Refused | Undone | NothingToUndo | UnknownInput


class Ending(enum.Enum):
    QUIT = "quit"  # q (or, in a stream, Enter)
    END_OF_INPUT = "end of input"
    INTERRUPTED = "interrupted"  # Ctrl-C while waiting for input or sampling


# --- the live side: servos and input --------------------------------------------------------------
class _EndOfInput(Exception):
    pass


def _line_reader(source: LineSource) -> Callable[[], str | None]:
    """The next line typed, None if nothing has been typed yet; ``_EndOfInput`` at the end."""
    next_line = source if callable(source) else functools.partial(next, iter(source))

    def read() -> str | None:
        try:
            return next_line()
        except (StopIteration, EOFError):
            raise _EndOfInput from None

    return read


def taught_joints(robot: Robot, names: Iterable[str] | None) -> tuple[Joint, ...]:
    """The joints named (all if None), in robot order; ``OptionError`` (``taught``) naming an
    unknown one."""
    if names is None:
        return robot.joints
    wanted = set(names)
    for name in wanted:
        if name not in robot.joint_names:
            raise OptionError(
                "taught",
                f"names an unknown joint {name!r}{did_you_mean(name, robot.joint_names)}; "
                f"{robot.name}'s joints are {', '.join(robot.joint_names)}",
            )
    if not wanted:
        raise OptionError(
            "taught",
            f"names no joint: name at least one; {robot.name}'s joints are "
            f"{', '.join(robot.joint_names)}",
        )
    return tuple(j for j in robot.joints if j.name in wanted)


def limit_problems(robot: Robot, angles_deg: Sequence[float]) -> list[str]:
    return [str(outside) for outside in robot.limit_violations(angles_deg)]


class Recorder:
    """Captures poses from the servos into ``recording``. Use as a context manager: entering
    unloads the taught joints (the others hold); leaving loads them again, holding where they
    are, unless ``leave_unloaded``."""

    def __init__(
        self,
        bus: ServoBus,
        recording: Recording,
        clock: Clock,
        *,
        taught: Iterable[str] | None = None,
        leave_unloaded: bool = False,
        on_event: Callable[[Event], None] = lambda event: None,
    ):
        self.bus = bus
        self.recording = recording
        self.robot = recording.robot
        self.clock = clock
        self.taught = taught_joints(self.robot, taught)
        self.held = tuple(j for j in self.robot.joints if j not in self.taught)
        self.leave_unloaded = leave_unloaded
        self.on_event = on_event
        self._session_start_s = clock.now()
        # When each capture was taken in this session (None: before a resume), for after_s.
        self._times: list[float | None] = [None] * len(recording.captures)

    def __enter__(self) -> Recorder:
        self._check_transport()
        self._check_servos()
        try:
            for joint in self.held:
                self.bus.load(joint.servo_id)
            for joint in self.taught:
                self.bus.unload(joint.servo_id)
            self.bus.drain()  # limp before the user is told to pose
        except BaseException:
            self._hold_taught(quietly=True)
            raise
        self._session_start_s = self.clock.now()
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        if not self.leave_unloaded:
            self._hold_taught(quietly=exc is not None)

    def _check_transport(self) -> None:
        """Before anything is unloaded: the joints must be able to hold again afterwards."""
        capabilities = self.bus.capabilities
        if not capabilities.load:
            raise UnsupportedByTransport(
                f"{self.bus.name}: recording by hand is refused through the "
                f"{capabilities.transport}: it cannot load (torque on) a servo again, so the "
                "unloaded joints would stay limp; connect the servos to the raw LX bus or an RRC "
                "board to record"
            )

    def _check_servos(self) -> None:
        missing = [j for j in self.robot.joints if not self.bus.ping(j.servo_id, retries=2)]
        if missing:
            names = ", ".join(f"{j.name} (ID {j.servo_id})" for j in missing)
            raise BusError(
                f"{len(missing)} servo(s) did not answer: {names}; check power and "
                "wiring, or run `choreo scan` to see which IDs answer"
            )
        if not self.bus.capabilities.supports(Command.OR_MOTOR_MODE_READ):
            return  # a board without the read (RRC): the mode cannot be checked
        spinning = [j for j in self.robot.joints if self.bus.read_mode(j.servo_id).motor]
        if spinning:
            raise BusError(
                "in motor mode: "
                + ", ".join(f"{j.name} (servo {j.servo_id})" for j in spinning)
                + ": stop their motors first (choreo.bus.servo_config.stop_motor)",
                servo_id=spinning[0].servo_id if len(spinning) == 1 else None,
                command=Command.OR_MOTOR_MODE_READ,
            )

    def _hold_taught(self, *, quietly: bool) -> None:
        """Load the taught joints again (a LOAD holds the current position)."""
        failed: dict[str, list[str]] = {}  # reason -> joints: a board's refusal once, not 18x
        for joint in self.taught:
            try:
                servo_config.set_torque(self.bus, joint.servo_id, True)
            except BusError as error:
                failed.setdefault(str(error), []).append(joint.name)
        if not failed:
            return
        message = "could not load again, so these joints may be limp: " + "; ".join(
            f"{', '.join(names)}: {reason}" for reason, names in failed.items()
        )
        if quietly:
            log.warning("%s", message)  # an error is on its way out already; don't hide it
        else:
            raise BusError(message)

    # --- captures ---------------------------------------------------------------------------------
    def read_pose(self) -> tuple[float, ...]:
        """Every joint's angle now, degrees in robot order (0.01° resolution)."""
        return tuple(
            round(j.to_deg(self.bus.read_position(j.servo_id)), ANGLE_DECIMALS) + 0.0
            for j in self.robot.joints
        )

    def capture(self, stream: int | None = None) -> Captured | Refused:
        """Read every joint and journal the pose, unless a joint is outside its limits."""
        now = self.clock.now()
        angles = self.read_pose()
        problems = limit_problems(self.robot, angles)
        if problems:
            return Refused(tuple(problems))
        capture = Capture(angles, self._after_s(now), stream)
        number = self.recording.add(capture)
        self._times.append(now)
        return Captured(number, capture)

    def _after_s(self, now: float) -> float | None:
        if not self._times:
            return None
        previous = self._times[-1]
        return now - (previous if previous is not None else self._session_start_s)

    def undo(self) -> Undone | NothingToUndo:
        number = self.recording.undo()
        if number is None:
            return NothingToUndo()
        self._times.pop()
        return Undone(number, len(self.recording.captures))

    # --- sessions ---------------------------------------------------------------------------------
    def run_keyframes(self, lines: LineSource) -> Ending:
        """Enter (an empty line) captures, ``u`` undoes, ``q`` quits; until q or end of input."""
        read = _line_reader(lines)
        while True:
            try:
                line = read()
            except _EndOfInput:
                return Ending.END_OF_INPUT
            except KeyboardInterrupt:
                return Ending.INTERRUPTED
            if line is None:
                continue
            command = line.strip().lower()
            if command == "":
                self.on_event(self.capture())
            elif command == "u":
                self.on_event(self.undo())
            elif command == "q":
                return Ending.QUIT
            else:
                self.on_event(UnknownInput(line))

    def run_stream(self, lines: LineSource, rate_hz: float) -> Ending:
        """Sample every joint at ``rate_hz`` until Enter or q (or end of input, or Ctrl-C).

        ``lines`` is asked after each sample (and every INPUT_POLL_S while a slow rate waits) and
        must not block: None means nothing typed.
        Samples run on absolute deadlines; a sample that is late skips the slots it missed.
        A joint leaving its limits is reported once per excursion; those samples are dropped.
        """
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        read = _line_reader(lines)
        stream = self.recording.next_stream()
        period_s = 1 / rate_hz
        start_s = self.clock.now()
        slot = 0
        outside = False
        try:
            while True:
                result = self.capture(stream)
                if isinstance(result, Captured) or not outside:
                    self.on_event(result)
                outside = isinstance(result, Refused)
                ending = self._typed(read)
                if ending is not None:
                    return ending
                slot = max(slot + 1, math.ceil((self.clock.now() - start_s) / period_s))
                ending = self._sleep_reading(start_s + slot * period_s, read)
                if ending is not None:
                    return ending
        except KeyboardInterrupt:
            return Ending.INTERRUPTED

    def _typed(self, read: Callable[[], str | None]) -> Ending | None:
        """How a line typed ends the stream (Enter or q), if one was typed."""
        try:
            line = read()
        except _EndOfInput:
            return Ending.END_OF_INPUT
        if line is None:
            return None
        if line.strip().lower() in ("", "q"):
            return Ending.QUIT
        self.on_event(UnknownInput(line))
        return None

    def _sleep_reading(self, deadline_s: float, read: Callable[[], str | None]) -> Ending | None:
        """Sleep until the next sample; a wait longer than INPUT_POLL_S (a slow rate) looks at
        what was typed every INPUT_POLL_S, so q acts at once and not a whole period later."""
        while deadline_s - self.clock.now() > INPUT_POLL_S:
            self.clock.sleep_until(self.clock.now() + INPUT_POLL_S)
            ending = self._typed(read)
            if ending is not None:
                return ending
        self.clock.sleep_until(deadline_s)
        return None
