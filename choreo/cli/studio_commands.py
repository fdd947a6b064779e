"""``choreo studio``: author a motion live in the browser (needs ``choreo[studio]``)."""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING

from choreo.cli.arguments import (
    add_port_arguments,
    bus_settings,
    file_path,
    say_built_in_emulator,
    stop_signals_as_ctrl_c,
)
from choreo.errors import UsageError
from choreo.studio.address import Address
from choreo.studio.serving import port_to_serve

if TYPE_CHECKING:
    from choreo.studio.live import LiveRobot

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8080
DEFAULT_LISTEN = f"{DEFAULT_HOST}:{DEFAULT_PORT}"


def listen_address(text: str) -> Address:
    """``HOST:PORT`` (``[::1]:8080`` for IPv6; port 0: any free port), or ``HOST`` alone: port
    8080, or the next free one."""
    if ":" not in text or (text.startswith("[") and text.endswith("]")):
        host = text.removeprefix("[").removesuffix("]")
        if host and not host.isdigit():  # "8080" is a port without its host
            return Address(host, DEFAULT_PORT, next_free=True)
    host, _, port = text.rpartition(":")
    host = host.removeprefix("[").removesuffix("]")
    if not host or not port.isdigit() or not 0 <= int(port) < 65536:
        raise argparse.ArgumentTypeError(
            f"expected HOST:PORT such as {DEFAULT_LISTEN} (port 0: any free port), or HOST, "
            f"got {text!r}"
        )
    return Address(host, int(port))


def register(subparsers) -> None:
    studio = subparsers.add_parser(
        "studio",
        help="author a motion live in the browser (needs choreo[studio])",
        description="Serve a page that shows the motion's robot from its MuJoCo model, planned "
        "and simulated as choreo preview does, and follows every save of the motion file, its "
        "includes, its robot and its song. Scrub and play the timeline, pose the robot with a "
        "slider per joint, and add, update, move or delete keyframes: the page writes them into "
        "the file, changing only the lines of that keyframe. Keep the file open in a text "
        "editor beside it: both edit the same file. With --port the page can drive the robot "
        "(after play's preflight, at the approach's speed; Stop stops it). See README, "
        "'Authoring live'.",
    )
    studio.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    studio.add_argument(
        "--listen",
        type=listen_address,
        default=Address(DEFAULT_HOST, DEFAULT_PORT, next_free=True),
        metavar="HOST:PORT",
        help=f"where the page is served (default {DEFAULT_LISTEN}, or the next free port if "
        "that is taken; a port named must be free, port 0 takes any free one); only this "
        "computer can open it unless you name another address",
    )
    add_port_arguments(studio)
    port = next(action for action in studio._actions if action.dest == "port")
    port.help = (
        "drive this robot from the page (serial port or URL as for play, e.g. /dev/ttyUSB0 or "
        "sim://?ids=1-6); without it nothing is driven"
    )
    studio.set_defaults(handler=run_studio)


def run_studio(args: argparse.Namespace) -> int:
    if not args.motion.is_file():
        raise UsageError(f"{args.motion}: no such motion file")
    # the address first, before the robot is driven or the studio loaded: a wrong one is one
    # line at once
    args.listen = Address(args.listen.host, port_to_serve(args.listen))
    with contextlib.ExitStack() as stack:
        live = None
        if args.port is not None:  # opt-in: only a port named on the command line is driven
            live = stack.enter_context(_live_robot(args))
        return _serve(args, live)


@contextlib.contextmanager
def _live_robot(args: argparse.Namespace) -> Iterator[LiveRobot]:
    """The motion's robot on --port, through play's preflight; stopped on every way out."""
    from choreo.motion.motion_file import load_motion
    from choreo.play.robot_bus import open_robot_bus
    from choreo.studio.live import LiveRobot

    robot = load_motion(args.motion).robot
    settings = bus_settings(args, robot)
    if settings.port is None:
        say_built_in_emulator(robot, "driving")
    bus = open_robot_bus(robot, None, settings)
    with stop_signals_as_ctrl_c(), bus:
        live = LiveRobot(bus, robot, bus.clock, say=_say)  # a sim:// URL's clock drives it too
        try:
            yield live
        finally:
            live.close()


def _say(line: str) -> None:
    print(line, flush=True)


def _serve(args: argparse.Namespace, live: LiveRobot | None) -> int:
    from choreo.studio.server import Studio  # MuJoCo and viser: loaded only for this command

    studio = Studio(args.motion, args.listen, say=_say, live=live)
    try:
        print(f"choreo studio: {studio.address.url}  (Ctrl-C to stop)", flush=True)
        studio.start()
        if not _is_loopback(studio.address.host):
            print(
                f"choreo studio: listening on {studio.address.host}: other computers can open "
                "the page and write to the motion file",
                file=sys.stderr,
            )
        studio.wait()
    finally:
        studio.close()
    return 0


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"
