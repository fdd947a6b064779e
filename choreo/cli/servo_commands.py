"""``choreo servo ...``: read and configure one servo (a cross-platform vendor tool replacement).

Settings the servo keeps across power-off show ``old → new`` and ask before writing (``--yes``
skips the question; without a terminal to ask on, they refuse). Every write is read back.
The logic is in ``choreo.bus.servo_config``; this module parses, asks and prints.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
from collections.abc import Callable

from rich.console import Console
from rich.table import Table

from choreo.bus import servo_config
from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.bus.servo_models import DEG_PER_UNIT
from choreo.bus.transports import Capabilities
from choreo.bus.typed_commands import AngleLimits, ServoInfo, VinLimits
from choreo.cli.arguments import add_port_arguments, finite_float, id_ranges, open_bus, servo_id
from choreo.errors import ChoreoError, OptionError, UsageError


# One statement per flag, in the order --help lists them: a long function, kept whole so that a
# command's usage reads top to bottom in one place.
def register(subparsers) -> None:
    servo = subparsers.add_parser(
        "servo",
        help="read and configure one servo",
        description="Read and configure one servo. Settings the servo saves (ID, offset, limits, "
        "LED) show old → new and ask before writing; every write is read back.",
    )
    actions = servo.add_subparsers(dest="servo_command", metavar="ACTION", required=True)

    info = _action(actions, "info", "show every readable parameter of one servo", run_info)
    info.add_argument("--json", action="store_true", help="machine-readable output")

    set_id = _action(
        actions, "set-id", "give a servo a new ID (saved)", run_set_id, needs_id=False, saves=True
    )
    set_id.add_argument("new_id", type=servo_id, metavar="NEW_ID", help="the new ID (0-253)")
    set_id.add_argument(
        "--id",
        type=servo_id,
        help="the servo's current ID; without it, the "
        "servo must be alone on the bus (found by a broadcast and a scan)",
    )
    set_id.add_argument(
        "--scan-ids",
        type=id_ranges,
        default=tuple(servo_config.ALL_IDS),
        metavar="RANGE",
        help="IDs the scan checks for other servos (default 0-253, about 10 s)",
    )

    offset = actions.add_parser("offset", help="trim the servo's zero (adjust, then save)")
    offset_actions = offset.add_subparsers(dest="offset_command", metavar="ACTION", required=True)
    adjust = _action(
        offset_actions,
        "adjust",
        "set the offset now (not saved; the output moves)",
        run_offset_adjust,
    )
    lo, hi = servo_config.field_range(Command.ANGLE_OFFSET_ADJUST, "offset_units")
    amount = adjust.add_mutually_exclusive_group(required=True)
    amount.add_argument(
        "--units",
        type=_whole("offset", lo, hi, " units"),
        help=f"offset in units of 0.24° ({lo}..{hi})",
    )
    amount.add_argument(
        "--deg",
        type=finite_float,
        help=f"offset in degrees "
        f"({lo * DEG_PER_UNIT:+.0f}..{hi * DEG_PER_UNIT:+.0f}), rounded to units",
    )
    _action(
        offset_actions, "save", "save the offset in use in the servo", run_offset_save, saves=True
    )

    limits = _action(
        actions, "limits", "set the servo's own angle limits (saved)", run_limits, saves=True
    )
    lo, hi = servo_config.field_range(Command.ANGLE_LIMIT_WRITE, "min_units")
    limits.add_argument(
        "--min",
        type=_whole("angle limit", lo, hi, " units"),
        required=True,
        metavar="UNITS",
        help=f"lowest position ({lo}..{hi}, 0.24° each)",
    )
    limits.add_argument(
        "--max",
        type=_whole("angle limit", lo, hi, " units"),
        required=True,
        metavar="UNITS",
        help=f"highest position ({lo}..{hi}), above --min",
    )

    vin = _action(
        actions, "vin-limits", "set the supply voltage limits (saved)", run_vin_limits, saves=True
    )
    lo, hi = servo_config.field_range(Command.VIN_LIMIT_WRITE, "min_mv")
    vin.add_argument(
        "--min",
        type=_whole("voltage limit", lo, hi, " mV"),
        required=True,
        metavar="MV",
        help=f"lowest supply, mV ({lo}..{hi})",
    )
    vin.add_argument(
        "--max",
        type=_whole("voltage limit", lo, hi, " mV"),
        required=True,
        metavar="MV",
        help=f"highest supply, mV ({lo}..{hi}), above --min",
    )

    temp = _action(
        actions, "temp-limit", "set the temperature limit (saved)", run_temp_limit, saves=True
    )
    lo, hi = servo_config.field_range(Command.TEMP_MAX_LIMIT_WRITE, "temp_c")
    temp.add_argument(
        "celsius",
        type=_whole("temperature limit", lo, hi, " °C"),
        metavar="CELSIUS",
        help=f"the servo unloads above this ({lo}..{hi} °C; factory 85)",
    )

    led = _action(actions, "led", "turn the LED on or off (saved)", run_led, saves=True)
    led.add_argument("state", choices=("on", "off"))

    led_errors = _action(
        actions,
        "led-errors",
        "choose the faults that flash the LED (saved)",
        run_led_errors,
        saves=True,
    )
    led_errors.add_argument(
        "mask",
        type=_error_mask,
        metavar="FAULTS",
        help="none, all, or a comma-separated list of "
        f"{', '.join(servo_config.ERROR_MASK_NAMES)} (or a number 0-7)",
    )

    move = _action(actions, "move", "move to a position (loads the servo)", run_move)
    lo, hi = servo_config.field_range(Command.MOVE_TIME_WRITE, "pos_units")
    target = move.add_mutually_exclusive_group(required=True)
    target.add_argument(
        "--pos",
        type=_whole("position", lo, hi, " units"),
        metavar="UNITS",
        help=f"target position ({lo}..{hi}, 0.24° each)",
    )
    target.add_argument(
        "--deg",
        type=finite_float,
        help=f"target servo angle "
        f"({lo * DEG_PER_UNIT:g}..{hi * DEG_PER_UNIT:g}°), rounded to units",
    )
    lo, hi = servo_config.field_range(Command.MOVE_TIME_WRITE, "time_ms")
    move.add_argument(
        "--time-ms",
        type=_whole("move time", lo, hi, " ms"),
        default=1000,
        help=f"how long the move takes ({lo}..{hi} ms, default 1000; 0 = full speed)",
    )

    _action(actions, "load", "torque on: hold the current position", run_load)
    _action(actions, "unload", "torque off: the servo can be turned by hand", run_unload)

    motor = _action(actions, "motor", "turn continuously (motor mode, not saved)", run_motor)
    lo, hi = servo_config.field_range(Command.OR_MOTOR_MODE_WRITE, "speed")
    speed = motor.add_mutually_exclusive_group(required=True)
    speed.add_argument(
        "--speed",
        type=_whole("motor speed", lo, hi, ""),
        help=f"duty {lo}..{hi}; negative turns the other way",
    )
    speed.add_argument(
        "--stop", action="store_true", help="back to servo mode, holding where it stopped"
    )


def _action(
    actions,
    name: str,
    help_text: str,
    handler: Callable,
    *,
    needs_id: bool = True,
    saves: bool = False,
) -> argparse.ArgumentParser:
    parser = actions.add_parser(
        name, help=help_text, description=help_text[0].upper() + help_text[1:] + "."
    )
    add_port_arguments(parser)
    if needs_id:
        parser.add_argument("--id", type=servo_id, required=True, help="the servo's ID (0-253)")
    if saves:
        parser.add_argument(
            "-y", "--yes", action="store_true", help="write without asking for confirmation"
        )
    parser.set_defaults(handler=_bad_values_are_usage_errors(handler))
    return parser


def _whole(what: str, lo: int, hi: int, unit: str) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(
                f"{what} must be a whole number in {lo}..{hi}{unit}, got {text!r}"
            )
        return value

    return parse


def _error_mask(text: str):
    try:
        return servo_config.parse_error_mask(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _bad_values_are_usage_errors(handler: Callable[[argparse.Namespace], int]):
    """A ValueError (a value the codec or workshop refuses) is a usage error, like argparse's."""

    @functools.wraps(handler)
    def run(args: argparse.Namespace) -> int:
        try:
            return handler(args)
        except OptionError:
            raise  # main() words it with the flag it names
        except ValueError as error:
            raise UsageError(str(error)) from error

    return run


# --- confirmation ------------------------------------------------------------------------------
def _confirm_and_write(args: argparse.Namespace, bus: ServoBus, change, apply) -> int:
    """Show old → new, ask (unless --yes), write and verify. 1 if declined, 0 if written."""
    print(change)
    if change.warning:
        print(f"warning: {change.warning}")
    if change.unchanged:
        print("already set: nothing written")
        return 0
    if not _confirmed(args.yes):
        print("nothing written")
        return 1
    apply(bus, change)
    print("written and verified")
    return 0


def _confirmed(yes: bool) -> bool:
    if yes:
        return True
    if not sys.stdin.isatty():
        raise ChoreoError(
            "nothing written: this change needs confirmation and stdin is not a "
            "terminal to ask on; add --yes to write without asking"
        )
    try:
        answer = input("write it to the servo? [y/N] ")
    except EOFError:
        return False
    return answer.strip().lower() in ("y", "yes")


# --- handlers ----------------------------------------------------------------------------------
def run_info(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        info = bus.read_info(args.id)
    if args.json:
        print(json.dumps(_jsonable(info), indent=2))
    else:
        Console().print(_info_table(info, bus.capabilities))
    return 0


def run_set_id(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        if args.id is None:
            print(
                f"looking for the one servo on the bus: a broadcast ID read, then a scan of "
                f"{len(args.scan_ids)} IDs",
                file=sys.stderr,
            )
        change = servo_config.plan_id_change(bus, args.new_id, args.id, args.scan_ids)
        return _confirm_and_write(args, bus, change, servo_config.apply_id_change)


def run_offset_adjust(args: argparse.Namespace) -> int:
    units = args.units if args.units is not None else servo_config.offset_units_from_deg(args.deg)
    with open_bus(args) as bus:
        servo_config.adjust_offset(bus, args.id, units)
    print(
        f"servo {args.id}: offset {servo_config.show_units(units)} in use (the output moved); "
        f"not saved: `choreo servo offset save --id {args.id}` keeps it across power-off"
    )
    return 0


def run_offset_save(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        change = servo_config.plan_offset_save(bus, args.id)
        return _confirm_and_write(args, bus, change, servo_config.apply_change)


def _write_setting(args: argparse.Namespace, setting: servo_config.Setting, value) -> int:
    with open_bus(args) as bus:
        change = servo_config.plan_change(bus, args.id, setting, value)
        return _confirm_and_write(args, bus, change, servo_config.apply_change)


def _min_below_max(args: argparse.Namespace, unit: str) -> None:
    """The codec's own message names its fields (min_units); the user typed --min and --max."""
    if args.min >= args.max:
        raise UsageError(f"--min {args.min}{unit} must be below --max {args.max}{unit}")


def run_limits(args: argparse.Namespace) -> int:
    _min_below_max(args, "")
    return _write_setting(args, servo_config.ANGLE_LIMITS, AngleLimits(args.min, args.max))


def run_vin_limits(args: argparse.Namespace) -> int:
    _min_below_max(args, " mV")
    return _write_setting(args, servo_config.VIN_LIMITS, VinLimits(args.min, args.max))


def run_temp_limit(args: argparse.Namespace) -> int:
    return _write_setting(args, servo_config.TEMP_LIMIT, args.celsius)


def run_led(args: argparse.Namespace) -> int:
    return _write_setting(args, servo_config.LED, args.state == "on")


def run_led_errors(args: argparse.Namespace) -> int:
    return _write_setting(args, servo_config.LED_ERRORS, args.mask)


def run_move(args: argparse.Namespace) -> int:
    pos = args.pos if args.pos is not None else servo_config.position_units_from_deg(args.deg)
    with open_bus(args) as bus:
        servo_config.move(bus, args.id, pos, args.time_ms)
    print(f"servo {args.id}: moving to {servo_config.show_units(pos)} in {args.time_ms} ms")
    return 0


def run_load(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        servo_config.set_torque(bus, args.id, True)
    print(f"servo {args.id}: loaded (holding its position)")
    return 0


def run_unload(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        verified = servo_config.set_torque(bus, args.id, False)
        transport = bus.capabilities.transport
    unread = "" if verified else f"; not read back: the {transport} cannot read the load state"
    print(f"servo {args.id}: unloaded (turns freely by hand{unread})")
    return 0


def run_motor(args: argparse.Namespace) -> int:
    with open_bus(args) as bus:
        if args.stop:
            servo_config.stop_motor(bus, args.id)
            print(f"servo {args.id}: servo mode, holding where it stopped")
            return 0
        servo_config.run_motor(bus, args.id, args.speed)
    print(
        f"servo {args.id}: motor mode at speed {args.speed} (not saved); "
        f"`choreo servo motor --id {args.id} --stop` ends it"
    )
    return 0


# --- info output -------------------------------------------------------------------------------
def _jsonable(info: ServoInfo) -> dict:
    values = dataclasses.asdict(info)
    if info.led_errors is not None:
        values["led_errors"] = [
            flag.name.lower()
            for flag in type(info.led_errors)
            if flag in info.led_errors and flag.name is not None  # members always have names
        ]
    return values


def _info_table(info: ServoInfo, capabilities: Capabilities) -> Table:
    def move(m, command: Command):
        if m is None:
            return shown(None, command, str)
        return f"{m.pos_units} in {m.time_ms} ms"

    def shown(value, command: Command, show) -> str:
        if value is not None:
            return show(value)
        if not capabilities.supports(command):
            return f"not readable through the {capabilities.transport}"
        return "not answered by this model"

    C = Command
    rows = [
        ("position", f"{info.pos_units} ({info.pos_units * DEG_PER_UNIT:.1f}°)"),
        ("last move", move(info.move, C.MOVE_TIME_READ)),
        ("staged move", move(info.staged_move, C.MOVE_TIME_WAIT_READ)),
        (
            "offset",
            shown(
                info.offset_units, C.ANGLE_OFFSET_READ, lambda o: f"{o} ({o * DEG_PER_UNIT:+.1f}°)"
            ),
        ),
        (
            "angle limits",
            shown(info.angle_limits, C.ANGLE_LIMIT_READ, lambda a: f"{a.min_units}..{a.max_units}"),
        ),
        (
            "vin limits",
            shown(info.vin_limits, C.VIN_LIMIT_READ, lambda v: f"{v.min_mv}..{v.max_mv} mV"),
        ),
        ("temperature limit", shown(info.temp_limit_c, C.TEMP_MAX_LIMIT_READ, "{} °C".format)),
        ("temperature", shown(info.temp_c, C.TEMP_READ, "{} °C".format)),
        ("vin", shown(info.vin_mv, C.VIN_READ, "{} mV".format)),
        (
            "mode",
            shown(
                info.mode,
                C.OR_MOTOR_MODE_READ,
                lambda m: f"motor, speed {m.speed}" if m.motor else "servo",
            ),
        ),
        (
            "torque",
            shown(info.loaded, C.LOAD_OR_UNLOAD_READ, lambda v: "loaded" if v else "unloaded"),
        ),
        ("led", shown(info.led_on, C.LED_CTRL_READ, lambda v: "on" if v else "off")),
        ("led flashes on", shown(info.led_errors, C.LED_ERROR_READ, servo_config.show_error_mask)),
        ("distance", shown(info.distance, C.DIS_READ, str)),
    ]
    table = Table(title=f"servo {info.servo_id}", show_header=False)
    table.add_column(style="bold")
    table.add_column()
    for name, value in rows:
        table.add_row(name, value)
    return table
