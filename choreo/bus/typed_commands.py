"""Each LX command as a typed method (``move``, ``read_position`` ...), what the reads return
(``MoveTime``, ``AngleLimits`` ...) and every readable parameter of a servo at once
(``read_info``, a ``ServoInfo``), over the two transactions a bus provides: ``send`` and
``request``. ``ServoBus`` provides them; these are what it offers on top, as python-can's
``BusABC`` offers its helpers over ``send`` and ``recv``."""

from __future__ import annotations

import abc
from dataclasses import dataclass

from choreo.bus.protocol import BROADCAST_ID, Command, ErrorMask
from choreo.bus.transports import Capabilities
from choreo.core.arguments import check_flag
from choreo.errors import BusTimeoutError


@dataclass(frozen=True)
class MoveTime:
    pos_units: int
    time_ms: int


@dataclass(frozen=True)
class AngleLimits:
    min_units: int
    max_units: int


@dataclass(frozen=True)
class VinLimits:
    min_mv: int
    max_mv: int


@dataclass(frozen=True)
class MotorMode:
    motor: bool  # False: servo (position) mode
    speed: int  # -1000..1000 duty in motor mode


@dataclass(frozen=True)
class ServoStatus:
    """What ``choreo scan`` shows: facts every model answers (None: the transport cannot read
    it)."""

    servo_id: int
    pos_units: int
    vin_mv: int | None
    temp_c: int | None


@dataclass(frozen=True)
class ServoInfo:
    """Every readable parameter of one servo; None where this model does not answer or the
    transport cannot read it (``ServoBus.capabilities`` tells which)."""

    servo_id: int
    pos_units: int
    move: MoveTime | None
    staged_move: MoveTime | None
    offset_units: int | None
    angle_limits: AngleLimits | None
    vin_limits: VinLimits | None
    temp_limit_c: int | None
    temp_c: int | None
    vin_mv: int | None
    mode: MotorMode | None
    loaded: bool | None
    led_on: bool | None
    led_errors: ErrorMask | None
    distance: int | None


class TypedCommands(abc.ABC):
    """The typed commands of a bus that can ``send`` a write and ``request`` a read."""

    capabilities: Capabilities  # what the transport can carry

    @abc.abstractmethod
    def send(self, command: Command, servo_id: int, /, **fields: int) -> None:
        """Send a write command (no reply exists for writes)."""

    @abc.abstractmethod
    def request(
        self,
        command: Command,
        servo_id: int,
        /,
        *,
        retries: int | None = None,
        timeout_s: float | None = None,
    ) -> dict[str, int]:
        """Send a read command and return its reply's fields, retrying on silence or garbage."""

    def move(self, servo_id: int, pos_units: int, time_ms: int) -> None:
        """MOVE_TIME_WRITE: move now, linearly, to ``pos_units`` over ``time_ms``."""
        self.send(Command.MOVE_TIME_WRITE, servo_id, pos_units=pos_units, time_ms=time_ms)

    def stage_move(self, servo_id: int, pos_units: int, time_ms: int) -> None:
        """MOVE_TIME_WAIT_WRITE: store a move that the next MOVE_START runs."""
        self.send(Command.MOVE_TIME_WAIT_WRITE, servo_id, pos_units=pos_units, time_ms=time_ms)

    def start(self, servo_id: int = BROADCAST_ID) -> None:
        """MOVE_START: run the staged move (every servo at once on broadcast)."""
        self.send(Command.MOVE_START, servo_id)

    def stop(self, servo_id: int = BROADCAST_ID) -> None:
        """MOVE_STOP: hold the current angle (servo mode only)."""
        self.send(Command.MOVE_STOP, servo_id)

    def load(self, servo_id: int = BROADCAST_ID) -> None:
        self.send(Command.LOAD_OR_UNLOAD_WRITE, servo_id, loaded=1)

    def unload(self, servo_id: int = BROADCAST_ID) -> None:
        """Torque off: the servo can be turned by hand."""
        self.send(Command.LOAD_OR_UNLOAD_WRITE, servo_id, loaded=0)

    def set_id(self, servo_id: int, new_id: int) -> None:
        """ID_WRITE, saved in the servo. Never broadcast (send() refuses): it would renumber
        every servo."""
        self.send(Command.ID_WRITE, servo_id, new_id=new_id)

    def adjust_offset(self, servo_id: int, offset_units: int) -> None:
        """ANGLE_OFFSET_ADJUST: applied at once, lost at power-off unless saved."""
        self.send(Command.ANGLE_OFFSET_ADJUST, servo_id, offset_units=offset_units)

    def save_offset(self, servo_id: int) -> None:
        self.send(Command.ANGLE_OFFSET_WRITE, servo_id)

    def set_angle_limits(self, servo_id: int, min_units: int, max_units: int) -> None:
        self.send(Command.ANGLE_LIMIT_WRITE, servo_id, min_units=min_units, max_units=max_units)

    def set_vin_limits(self, servo_id: int, min_mv: int, max_mv: int) -> None:
        self.send(Command.VIN_LIMIT_WRITE, servo_id, min_mv=min_mv, max_mv=max_mv)

    def set_temp_limit(self, servo_id: int, temp_c: int) -> None:
        self.send(Command.TEMP_MAX_LIMIT_WRITE, servo_id, temp_c=temp_c)

    def set_motor_mode(self, servo_id: int, speed: int) -> None:
        """Continuous rotation at a duty of ``speed`` (-1000..1000); not saved."""
        self.send(Command.OR_MOTOR_MODE_WRITE, servo_id, mode=1, reserved=0, speed=speed)

    def set_servo_mode(self, servo_id: int) -> None:
        self.send(Command.OR_MOTOR_MODE_WRITE, servo_id, mode=0, reserved=0, speed=0)

    def set_led(self, servo_id: int, on: bool) -> None:
        self.send(Command.LED_CTRL_WRITE, servo_id, led_off=0 if check_flag("on", on) else 1)

    def set_led_errors(self, servo_id: int, mask: ErrorMask | int) -> None:
        """Which faults make the LED flash."""
        self.send(Command.LED_ERROR_WRITE, servo_id, mask=int(mask))

    def read_position(self, servo_id: int) -> int:
        """Position in units; may be negative or above 1000 near the ends of travel."""
        return self.request(Command.POS_READ, servo_id)["pos_units"]

    def read_move(self, servo_id: int) -> MoveTime:
        return MoveTime(**self.request(Command.MOVE_TIME_READ, servo_id))

    def read_staged_move(self, servo_id: int) -> MoveTime:
        """MOVE_TIME_WAIT_READ; LX-16A servos never answer it."""
        return MoveTime(**self.request(Command.MOVE_TIME_WAIT_READ, servo_id))

    def read_id(self, servo_id: int = BROADCAST_ID) -> int:
        """ID_READ; on broadcast only safe with a single servo on the bus."""
        return self.request(Command.ID_READ, servo_id)["servo_id"]

    def read_offset(self, servo_id: int) -> int:
        return self.request(Command.ANGLE_OFFSET_READ, servo_id)["offset_units"]

    def read_angle_limits(self, servo_id: int) -> AngleLimits:
        return AngleLimits(**self.request(Command.ANGLE_LIMIT_READ, servo_id))

    def read_vin_limits(self, servo_id: int) -> VinLimits:
        return VinLimits(**self.request(Command.VIN_LIMIT_READ, servo_id))

    def read_temp_limit(self, servo_id: int) -> int:
        return self.request(Command.TEMP_MAX_LIMIT_READ, servo_id)["temp_c"]

    def read_temperature(self, servo_id: int) -> int:
        return self.request(Command.TEMP_READ, servo_id)["temp_c"]

    def read_vin(self, servo_id: int) -> int:
        return self.request(Command.VIN_READ, servo_id)["vin_mv"]

    def read_mode(self, servo_id: int) -> MotorMode:
        fields = self.request(Command.OR_MOTOR_MODE_READ, servo_id)
        return MotorMode(motor=fields["mode"] == 1, speed=fields["speed"])

    def read_loaded(self, servo_id: int) -> bool:
        return self.request(Command.LOAD_OR_UNLOAD_READ, servo_id)["loaded"] == 1

    def read_led(self, servo_id: int) -> bool:
        """True when the LED is on (the wire says 0 for on)."""
        return self.request(Command.LED_CTRL_READ, servo_id)["led_off"] == 0

    def read_led_errors(self, servo_id: int) -> ErrorMask:
        return ErrorMask(self.request(Command.LED_ERROR_READ, servo_id)["mask"] & 7)

    def read_distance(self, servo_id: int) -> int:
        """DIS_READ: rotation distance, 4096 pulses per turn; only some models answer."""
        return self.request(Command.DIS_READ, servo_id)["distance"]

    # --- a servo's whole state ---------------------------------------------------------------
    def read_status(self, servo_id: int) -> ServoStatus:
        can = self.capabilities.supports
        return ServoStatus(
            servo_id,
            self.read_position(servo_id),
            self.read_vin(servo_id) if can(Command.VIN_READ) else None,
            self.read_temperature(servo_id) if can(Command.TEMP_READ) else None,
        )

    def read_info(self, servo_id: int) -> ServoInfo:
        """Every readable parameter; commands this model ignores give None (one short try), and
        so do those the transport cannot carry."""

        def read(command: Command, reader):
            return reader(servo_id) if self.capabilities.supports(command) else None

        C = Command
        return ServoInfo(
            servo_id=servo_id,
            pos_units=self.read_position(servo_id),
            move=read(C.MOVE_TIME_READ, self.read_move),
            staged_move=_maybe(MoveTime, read(C.MOVE_TIME_WAIT_READ, self._try_staged_move)),
            offset_units=read(C.ANGLE_OFFSET_READ, self.read_offset),
            angle_limits=read(C.ANGLE_LIMIT_READ, self.read_angle_limits),
            vin_limits=read(C.VIN_LIMIT_READ, self.read_vin_limits),
            temp_limit_c=read(C.TEMP_MAX_LIMIT_READ, self.read_temp_limit),
            temp_c=read(C.TEMP_READ, self.read_temperature),
            vin_mv=read(C.VIN_READ, self.read_vin),
            mode=read(C.OR_MOTOR_MODE_READ, self.read_mode),
            loaded=read(C.LOAD_OR_UNLOAD_READ, self.read_loaded),
            led_on=read(C.LED_CTRL_READ, self.read_led),
            led_errors=read(C.LED_ERROR_READ, self.read_led_errors),
            distance=_maybe(int, read(C.DIS_READ, self._try_distance), "distance"),
        )

    def _try_staged_move(self, servo_id: int) -> dict[str, int] | None:
        return self._try_request(Command.MOVE_TIME_WAIT_READ, servo_id)

    def _try_distance(self, servo_id: int) -> dict[str, int] | None:
        return self._try_request(Command.DIS_READ, servo_id)

    def _try_request(self, command: Command, servo_id: int) -> dict[str, int] | None:
        """One try of a read that some models ignore."""
        try:
            return self.request(command, servo_id, retries=0)
        except BusTimeoutError:
            return None


def _maybe(make, fields: dict[str, int] | None, key: str | None = None):
    if fields is None:
        return None
    return make(fields[key]) if key else make(**fields)
