"""``choreo emulate``: the servo emulator on a pseudo-terminal."""

from __future__ import annotations

import argparse
import signal
import sys

from choreo.bus.servo_models import SERVO_MODELS
from choreo.cli.arguments import STOP_SIGNALS, non_negative_float
from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator, parse_servo_specs
from choreo.emulator.boards import BOARDS
from choreo.emulator.bus_emulator import (
    DEFAULT_START_GAP_S,
    DEFAULT_TURNAROUND_S,
    MAX_TURNAROUND_MS,
)
from choreo.emulator.pty import PtyBridge

EMULATE_LOG_LIMIT = 1000


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "emulate",
        help="emulate a bus of servos on a pseudo-terminal",
        description="Emulate servos on a pseudo-terminal that any program can open like a USB "
        "adapter (any baud setting works). Runs until Ctrl-C or SIGTERM.",
    )
    parser.add_argument(
        "--pty",
        type=pty_path,
        required=True,
        metavar="PATH",
        help="create a symlink at PATH to the pseudo-terminal",
    )
    parser.add_argument(
        "--servos",
        default="1-6",
        type=_servo_list,
        metavar="IDS",
        help="servo IDs, e.g. 1-6,9,12-14; a group may name its model: "
        "1-6,7:LX-224HV (default 1-6)",
    )
    parser.add_argument(
        "--model",
        default="LX-16A",
        choices=sorted(SERVO_MODELS),
        help="servo model (default LX-16A)",
    )
    parser.add_argument(
        "--echo", action="store_true", help="echo the host's bytes back, like one-wire DIY wiring"
    )
    parser.add_argument(
        "--state",
        metavar="FILE",
        help="keep the servos' EEPROM (IDs, offsets, limits) in this JSON file",
    )
    parser.add_argument(
        "--turnaround-ms",
        type=turnaround_ms,
        default=DEFAULT_TURNAROUND_S * 1000,
        metavar="X",
        help=f"delay before a servo answers, 0-{MAX_TURNAROUND_MS:g} ms (default 0.6)",
    )
    parser.add_argument(
        "--start-gap-ms",
        type=non_negative_float,
        default=DEFAULT_START_GAP_S * 1000,
        metavar="X",
        help="fault: a servo misses a MOVE_START that comes less than X ms after its staged "
        "move, as real servos can (default 0: never missed)",
    )
    parser.add_argument(
        "--board",
        choices=sorted(BOARDS),
        help="put an emulated controller board in front of the servos: rrc (open it as "
        "rrc://PATH) or lobot (its UART: lobot://PATH)",
    )
    parser.set_defaults(handler=run)


def pty_path(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "the path is empty: give a path for the link, e.g. /tmp/ttyCHOREO"
        )
    return text


def turnaround_ms(text: str) -> float:
    value = non_negative_float(text)
    if value > MAX_TURNAROUND_MS:
        raise argparse.ArgumentTypeError(
            f"expected a number in 0..{MAX_TURNAROUND_MS:g} ms, got {text!r}"
        )
    return value


def _servo_list(text: str) -> tuple[str, list]:
    try:
        return text, parse_servo_specs(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def build_emulator(args) -> BusEmulator:
    """The emulator the command line describes, in real time: the servos, or a board in front."""
    _, specs = args.servos
    return (BOARDS[args.board] if args.board else BusEmulator)(
        specs,
        model=args.model,
        clock=RealClock(),
        turnaround_s=args.turnaround_ms / 1000,
        echo=args.echo,
        start_gap_s=args.start_gap_ms / 1000,
        state_path=args.state,
        # Nothing reads this process's wire log; a long one makes the garbage collector stall
        # replies for tens of milliseconds as it fills.
        log_limit=EMULATE_LOG_LIMIT,
    )


def run(args) -> int:
    servos_text, _ = args.servos
    if args.board and args.echo:
        print("choreo: error: --echo: a board's link does not echo", file=sys.stderr)
        return 2
    emulator = build_emulator(args)
    stopped_by: list[int] = []

    def stop(signum, frame) -> None:
        stopped_by.append(signum)
        bridge.stop()

    with PtyBridge(emulator, args.pty) as bridge:
        if bridge.replaced_target is not None:
            print(
                f"choreo: note: replaced {args.pty}, left linking to {bridge.replaced_target} "
                "by an emulator that is gone",
                file=sys.stderr,
            )
        previous = {
            signum: signal.signal(signum, stop) for signum in (signal.SIGINT, *STOP_SIGNALS)
        }
        try:
            print(
                f"emulating servos {servos_text} ({args.model}) "
                f"{f'behind the {args.board} board ' if args.board else ''}on {args.pty} -> "
                f"{bridge.slave_name}; Ctrl-C to stop",
                flush=True,
            )
            bridge.serve_forever()
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
    if args.state:
        emulator.save_state()
    # as a shell reports a process ended by a signal: 130 after Ctrl-C, 143 after SIGTERM
    return 128 + stopped_by[0] if stopped_by else 0
