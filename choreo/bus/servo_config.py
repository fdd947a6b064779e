"""Configuring one servo: the logic behind ``choreo servo ...`` (the CLI only asks and prints).

Settings the servo keeps across power-off (ID, saved offset, angle/VIN/temperature limits, LED,
LED fault mask) are changed in two steps, so the user can confirm ``old → new`` in between:
``plan_*`` checks the new value (``ValueError`` naming the valid range, before anything is sent)
and reads the old one; ``apply_*`` writes, reads back and raises ``BusError`` naming the value
if the servo does not report what was written (the protocol has no ACK: a read-back is the only
way to know a write took).

``ID_WRITE`` is never broadcast. Without a known current ID, the one servo on the bus is found by
a broadcast ``ID_READ`` *and* a scan: a second servo would be renumbered too.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from choreo.bus.protocol import (
    BROADCAST_ID,
    MAX_SERVO_ID,
    Command,
    ErrorMask,
    check_request,
    field_range,
)
from choreo.bus.servo_bus import Presence, ServoBus
from choreo.bus.servo_models import DEG_PER_UNIT, UNITS_PER_DEG
from choreo.bus.typed_commands import AngleLimits, VinLimits
from choreo.errors import BusError, BusTimeoutError, OptionError, ProtocolError

log = logging.getLogger(__name__)

ALL_IDS = range(MAX_SERVO_ID + 1)
ERROR_MASK_NAMES = {
    "over-temperature": ErrorMask.OVER_TEMPERATURE,
    "voltage": ErrorMask.VOLTAGE,
    "stalled": ErrorMask.STALLED,
}


# --- settings kept in EEPROM -------------------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    """One EEPROM setting: how to check a new value, write it, read it back and show it."""

    name: str
    command: Command  # the write command: its fields' ranges say which values are valid
    fields: Callable[[Any], dict[str, int]]  # value -> the write command's fields
    write: Callable[[ServoBus, int, Any], None]  # the bus's typed setter
    read: Callable[[ServoBus, int], Any]
    show: Callable[[Any], str]
    # A warning about what the new value does at once (e.g. a limit the servo already exceeds).
    warn: Callable[[ServoBus, int, Any], str | None] = lambda bus, servo_id, value: None

    def check(self, value: Any) -> None:
        """``ValueError`` naming the field and its valid range if ``value`` cannot be written."""
        check_request(self.command, **self.fields(value))


def show_units(units: int) -> str:
    return f"{units} ({units * DEG_PER_UNIT:.1f}°)"


def show_error_mask(mask: ErrorMask) -> str:
    names = [name for name, flag in ERROR_MASK_NAMES.items() if flag in mask]
    return ", ".join(names) or "nothing"


def parse_error_mask(text: str) -> ErrorMask:
    """``none``, ``all``, a number 0-7, or names joined by commas: ``over-temperature,stalled``."""
    words = [w for w in text.replace(" ", "").lower().split(",") if w]
    valid = f"none, all, 0-7, or a comma-separated list of {', '.join(ERROR_MASK_NAMES)}"
    if words in (["none"], ["0"]):
        return ErrorMask.NONE
    if words == ["all"]:
        return ErrorMask(7)
    if len(words) == 1 and words[0].isdigit():
        if int(words[0]) > 7:
            raise ValueError(f"a fault mask number must be 0-7, got {text!r}; valid: {valid}")
        return ErrorMask(int(words[0]))
    mask = ErrorMask.NONE
    for word in words:
        if word not in ERROR_MASK_NAMES:
            raise ValueError(f"unknown fault {word!r}; valid: {valid}")
        mask |= ERROR_MASK_NAMES[word]
    if not words:
        raise ValueError(f"no faults given; valid: {valid}")
    return mask


def _warn_vin(bus: ServoBus, servo_id: int, limits: VinLimits) -> str | None:
    vin_mv = bus.read_vin(servo_id)
    if limits.min_mv <= vin_mv <= limits.max_mv:
        return None
    return (
        f"the supply reads {vin_mv} mV now, outside the new limits: the servo will unload at "
        "once and refuse to move until the supply is inside them"
    )


def _warn_temp(bus: ServoBus, servo_id: int, temp_c: int) -> str | None:
    now_c = bus.read_temperature(servo_id)
    if now_c <= temp_c:
        return None
    return (
        f"the servo is at {now_c} °C now, above the new limit: it will unload at once and "
        "refuse to move until it has cooled down"
    )


def _warn_angle(bus: ServoBus, servo_id: int, limits: AngleLimits) -> str | None:
    pos_units = bus.read_position(servo_id)
    if limits.min_units <= pos_units <= limits.max_units:
        return None
    return (
        f"the servo stands at {pos_units}, outside the new limits: its next move will end at "
        "the nearer limit"
    )


TEMP_LIMIT = Setting(
    "temperature limit",
    Command.TEMP_MAX_LIMIT_WRITE,
    lambda c: dict(temp_c=c),
    ServoBus.set_temp_limit,
    ServoBus.read_temp_limit,
    lambda c: f"{c} °C",
    _warn_temp,
)
ANGLE_LIMITS = Setting(
    "angle limits",
    Command.ANGLE_LIMIT_WRITE,
    lambda v: dict(min_units=v.min_units, max_units=v.max_units),
    lambda bus, servo_id, v: bus.set_angle_limits(servo_id, v.min_units, v.max_units),
    ServoBus.read_angle_limits,
    lambda v: f"{show_units(v.min_units)}..{show_units(v.max_units)}",
    _warn_angle,
)
VIN_LIMITS = Setting(
    "supply voltage limits",
    Command.VIN_LIMIT_WRITE,
    lambda v: dict(min_mv=v.min_mv, max_mv=v.max_mv),
    lambda bus, servo_id, v: bus.set_vin_limits(servo_id, v.min_mv, v.max_mv),
    ServoBus.read_vin_limits,
    lambda v: f"{v.min_mv}..{v.max_mv} mV",
    _warn_vin,
)
LED = Setting(
    "LED",
    Command.LED_CTRL_WRITE,
    lambda on: dict(led_off=0 if on else 1),
    ServoBus.set_led,
    ServoBus.read_led,
    lambda on: "on" if on else "off",
)
LED_ERRORS = Setting(
    "faults that flash the LED",
    Command.LED_ERROR_WRITE,
    lambda mask: dict(mask=int(mask)),
    ServoBus.set_led_errors,
    ServoBus.read_led_errors,
    show_error_mask,
)
SAVED_OFFSET = Setting(
    "saved offset",
    Command.ANGLE_OFFSET_WRITE,
    lambda units: {},
    lambda bus, servo_id, units: bus.save_offset(servo_id),
    ServoBus.read_offset,
    lambda units: (
        "unknown (servos report only the offset in use)" if units is None else show_units(units)
    ),
)


@dataclass(frozen=True)
class Change:
    """An EEPROM write about to happen: what the user confirms."""

    servo_id: int
    setting: Setting
    old: Any  # None: the servo cannot report it
    new: Any
    warning: str | None = None

    @property
    def unchanged(self) -> bool:
        return self.old == self.new

    def __str__(self) -> str:
        return (
            f"servo {self.servo_id}: {self.setting.name} {self.setting.show(self.old)} → "
            f"{self.setting.show(self.new)}"
        )


def plan_change(bus: ServoBus, servo_id: int, setting: Setting, new: Any) -> Change:
    """Check ``new`` (``ValueError``), then read the old value and any warning; writes nothing."""
    setting.check(new)
    _check_addressable(servo_id)
    old = setting.read(bus, servo_id)
    return Change(servo_id, setting, old, new, setting.warn(bus, servo_id, new))


def plan_offset_save(bus: ServoBus, servo_id: int) -> Change:
    """Saving the offset in use. The servo reports only the offset in use, not the saved one."""
    _check_addressable(servo_id)
    return Change(servo_id, SAVED_OFFSET, None, bus.read_offset(servo_id))


def apply_change(bus: ServoBus, change: Change) -> None:
    """Write, read back, and raise ``BusError`` naming the value unless it reads as written."""
    setting = change.setting
    setting.write(bus, change.servo_id, change.new)
    _verify(
        bus,
        change.servo_id,
        setting.name,
        setting.show(change.new),
        lambda: setting.read(bus, change.servo_id),
        change.new,
        setting.show,
    )


def _verify(
    bus: ServoBus,
    servo_id: int,
    what: str,
    written: str,
    read: Callable[[], Any],
    expected: Any,
    show: Callable[[Any], str],
) -> None:
    try:
        actual = read()
    except (BusTimeoutError, ProtocolError) as error:
        raise BusError(
            f"servo {servo_id}: wrote {what} {written} but could not read it back, so "
            f"it may not have taken: {error}"
        ) from error
    if actual != expected:
        raise BusError(
            f"servo {servo_id}: {what} reads {show(actual)} after writing {written}: the "
            "write did not take (a packet lost on the wire?); check the wiring and try "
            "again"
        )


def _check_addressable(servo_id: int) -> None:
    if not 0 <= servo_id <= MAX_SERVO_ID:
        raise ValueError(
            f"servo_id must be a servo's own ID 0..{MAX_SERVO_ID} (no broadcast), got {servo_id}"
        )


# --- the servo ID ------------------------------------------------------------------------------
@dataclass(frozen=True)
class IdChange:
    """Renumbering one servo, addressed by its current ID."""

    current_id: int
    new_id: int
    found_alone: bool  # True: the current ID was found by broadcast and scan, not given
    warning: str | None = None  # (nothing to warn about; shaped like Change for the CLI)

    @property
    def unchanged(self) -> bool:
        return self.current_id == self.new_id

    def __str__(self) -> str:
        alone = " (the only servo on the bus)" if self.found_alone else ""
        return f"servo ID {self.current_id} → {self.new_id}{alone}"


def find_single_servo(bus: ServoBus, scan_ids: Iterable[int] = ALL_IDS) -> int:
    """The ID of the one servo on the bus; ``BusError`` listing what answers otherwise.

    A broadcast ID_READ is answered by every servo (colliding replies if there are several); a
    scan of ``scan_ids`` then makes sure nobody else is there, e.g. a servo whose reply was lost,
    and names the servos found when there are several.
    """
    collided = False
    try:
        found = {bus.read_id(BROADCAST_ID)}
    except ProtocolError:
        found, collided = set(), True
    except BusTimeoutError:
        found = set()
    scan = bus.scan_presence(sorted(set(scan_ids) | found))
    if found and list(scan.found) == sorted(found) and not scan.garbled:
        return scan.found[0]
    if not (scan.found or scan.garbled or found or collided):
        raise BusError("no servo answered a broadcast ID read nor the scan: check power and wiring")
    reasons = []
    if collided:
        reasons.append(
            "several servos answered a broadcast ID read at once (their replies collided)"
        )
    answering = sorted(set(scan.found) | found)
    if answering:
        reasons.append(f"IDs {', '.join(map(str, answering))} answer")
    if scan.garbled:
        reasons.append(
            f"replies at IDs {', '.join(map(str, scan.garbled))} are garbled (several "
            "servos share each of these IDs)"
        )
    if not (answering or scan.garbled):
        reasons.append("no ID answers the scan alone")
    raise BusError.naming(
        "current_id",
        "setting an ID without its current one needs exactly one servo on the bus, but "
        f"{'; '.join(reasons)}: connect only the servo to renumber, or give its "
        "current ID ({option})",
    )


def plan_id_change(
    bus: ServoBus, new_id: int, current_id: int | None = None, scan_ids: Iterable[int] = ALL_IDS
) -> IdChange:
    """Check ``new_id`` and find the servo to renumber; refuse an ID already in use."""
    check_request(Command.ID_WRITE, new_id=new_id)  # ValueError with the valid range
    if current_id is None:
        current_id = find_single_servo(bus, scan_ids)
        change = IdChange(current_id, new_id, found_alone=True)
    else:
        _check_addressable(current_id)
        presence = bus.presence(current_id, retries=2)
        if presence is Presence.GARBLED:
            raise BusError(
                f"replies at ID {current_id} are garbled: several servos share it, and "
                "ID_WRITE would renumber them all; connect only the servo to renumber"
            )
        if presence is Presence.SILENT:
            raise BusError(
                f"no servo answers at ID {current_id}: check the ID (`choreo scan`), "
                "power and wiring"
            )
        change = IdChange(current_id, new_id, found_alone=False)
    if not change.unchanged and bus.presence(new_id, retries=1) is not Presence.SILENT:
        raise BusError(
            f"ID {new_id} is already used by another servo on the bus: two servos with one ID "
            "garble each other's replies; choose a free ID (`choreo scan` lists those in use)"
        )
    return change


def apply_id_change(bus: ServoBus, change: IdChange) -> None:
    """ID_WRITE to the servo's own ID (never broadcast), then check it answers at the new one."""
    bus.set_id(change.current_id, change.new_id)
    if bus.ping(change.new_id, retries=2):
        return  # a reply from new_id carries new_id in its header and its data
    still = bus.ping(change.current_id, retries=1)
    where = f"it still answers at {change.current_id}" if still else "nor at its old ID"
    raise BusError(
        f"servo ID {change.current_id}: wrote ID {change.new_id} but no servo answers "
        f"at {change.new_id} ({where}): the write did not take; check the wiring and "
        "try again"
    )


# --- settings applied at once (not saved) ------------------------------------------------------
def _nearest_units(angle_deg: float, lo: int, hi: int) -> int | None:
    """The whole number of units nearest ``angle_deg`` if it is in ``lo..hi``, else ``None``.
    Compared before rounding: a huge angle (1e308°) is infinite in units, which can't be
    rounded; NaN is refused too."""
    units = angle_deg * UNITS_PER_DEG
    if not lo - 1 < units < hi + 1:
        return None
    rounded = round(units)
    return rounded if lo <= rounded <= hi else None


def offset_units_from_deg(offset_deg: float) -> int:
    """The nearest offset in units (0.24° each); ``OptionError`` with the range in both units."""
    lo, hi = field_range(Command.ANGLE_OFFSET_ADJUST, "offset_units")
    units = _nearest_units(offset_deg, lo, hi)
    if units is None:
        raise OptionError(
            "offset_deg",
            f"must be within {lo * DEG_PER_UNIT:+.1f}..{hi * DEG_PER_UNIT:+.1f}° ({lo}..{hi} "
            f"units), got {offset_deg:g}°",
        )
    return units


def adjust_offset(bus: ServoBus, servo_id: int, offset_units: int) -> None:
    """ANGLE_OFFSET_ADJUST (the output moves at once; lost at power-off unless saved), verified."""
    check_request(Command.ANGLE_OFFSET_ADJUST, offset_units=offset_units)
    _check_addressable(servo_id)
    bus.adjust_offset(servo_id, offset_units)
    _verify(
        bus,
        servo_id,
        "offset",
        show_units(offset_units),
        lambda: bus.read_offset(servo_id),
        offset_units,
        show_units,
    )


def position_units_from_deg(angle_deg: float) -> int:
    """The nearest servo position (0..240° → 0..1000 units)."""
    lo, hi = field_range(Command.MOVE_TIME_WRITE, "pos_units")
    units = _nearest_units(angle_deg, lo, hi)
    if units is None:
        raise OptionError(
            "angle_deg",
            f"must be in {lo * DEG_PER_UNIT:g}..{hi * DEG_PER_UNIT:g}° ({lo}..{hi} units), "
            f"got {angle_deg:g}°",
        )
    return units


def move(bus: ServoBus, servo_id: int, pos_units: int, time_ms: int) -> None:
    """MOVE_TIME_WRITE, refused where the servo would silently not do it: outside its own angle
    limits (it would stop at the limit) or in motor mode (it ignores moves)."""
    check_request(Command.MOVE_TIME_WRITE, pos_units=pos_units, time_ms=time_ms)
    _check_addressable(servo_id)
    limits = bus.read_angle_limits(servo_id)
    if not limits.min_units <= pos_units <= limits.max_units:
        raise BusError(
            f"servo {servo_id}: position {pos_units} is outside its angle limits "
            f"{limits.min_units}..{limits.max_units}, so it would stop at the nearer limit; "
            "choose a position inside them or widen them with `choreo servo limits`"
        )
    if bus.read_mode(servo_id).motor:
        raise BusError(
            f"servo {servo_id} is in motor mode and ignores moves: stop its motor first "
            "(stop_motor)",
            servo_id=servo_id,
            command=Command.OR_MOTOR_MODE_READ,
        )
    bus.move(servo_id, pos_units, time_ms)


def set_torque(bus: ServoBus, servo_id: int, loaded: bool) -> bool:
    """Load (hold) or unload (limp) a servo, verified where the transport can read the state
    back (a servo with a fault refuses to load); False: sent but not read back (the LOBOT
    controller unloads but cannot read), for the caller to say so."""
    _check_addressable(servo_id)
    if loaded:
        bus.load(servo_id)
    else:
        bus.unload(servo_id)
    if not bus.capabilities.supports(Command.LOAD_OR_UNLOAD_READ):
        return False
    if bus.read_loaded(servo_id) != loaded:
        if loaded:
            raise BusError(
                f"servo {servo_id} did not load: it refuses while over its temperature "
                "or outside its supply limits; see `choreo servo info`"
            )
        raise BusError(f"servo {servo_id} still reports torque on after UNLOAD: try again")
    return True


def run_motor(bus: ServoBus, servo_id: int, speed: int) -> None:
    """Continuous rotation at ``speed`` (-1000..1000, not saved), verified."""
    check_request(Command.OR_MOTOR_MODE_WRITE, mode=1, reserved=0, speed=speed)
    _check_addressable(servo_id)
    bus.set_motor_mode(servo_id, speed)
    mode = bus.read_mode(servo_id)
    if not mode.motor or mode.speed != speed:
        raise BusError(
            f"servo {servo_id}: motor mode reads {mode} after setting speed {speed}: "
            "the write did not take; check the wiring and try again"
        )


def stop_motor(bus: ServoBus, servo_id: int) -> None:
    """Back to servo (position) mode, holding where the output is; verified."""
    _check_addressable(servo_id)
    bus.set_servo_mode(servo_id)
    if bus.read_mode(servo_id).motor:
        raise BusError(
            f"servo {servo_id} is still in motor mode: the write did not take; try again"
        )
