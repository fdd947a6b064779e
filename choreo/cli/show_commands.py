"""``choreo perform`` (on each robot's computer) and ``choreo show`` (the conductor).

Zenoh (``choreo[show]``) is imported only when one of them runs, so every other command works
without it. What only one of them uses is imported by its handler (``loads``): a performer never
loads rich, the song's decoder or the show file's reader (some 0.05 s of CPU at each start),
and ``choreo --help`` none of it.
"""

from __future__ import annotations

import argparse
import socket
import sys
import time
from typing import TYPE_CHECKING

from choreo.cli.arguments import (
    add_port_arguments,
    bus_settings,
    file_path,
    float_in,
    loads,
    say_built_in_emulator,
    stop_signals_as_ctrl_c,
)
from choreo.core.atomic import check_writable
from choreo.errors import ChoreoError
from choreo.show.names import NAME_RULE, is_name, name_from

if TYPE_CHECKING:
    from rich.progress import Progress
    from rich.table import Table

    from choreo.bus.servo_bus import ServoBus
    from choreo.robot.types import Robot
    from choreo.show.showfile import Show

MAX_WAIT_S = 3600.0
DEFAULT_MAX_SILENCE_MS = 400.0  # choreo.show.performer.DEFAULT_MAX_SILENCE_S, without zenoh


def register(subparsers) -> None:
    perform = subparsers.add_parser(
        "perform",
        help="take part in shows: dance the parts a conductor (choreo show) sends",
        description="Announce this robot to the network and dance the parts that a "
        "`choreo show` sends: each is planned here, preflighted on this bus, and played from "
        "the show's start instant. Losing the conductor stops the servos. Runs until Ctrl-C.",
    )
    perform.add_argument(
        "--name",
        type=performer_name,
        help="the name the show file gives this robot (default: the host name)",
    )
    perform.add_argument(
        "--max-silence-ms",
        type=float_in(0, 60_000, " ms"),
        default=DEFAULT_MAX_SILENCE_MS,
        metavar="MS",
        help="stop the servos when the conductor's heartbeat (every 100 ms) has been silent this "
        f"long (default {DEFAULT_MAX_SILENCE_MS:g} ms)",
    )
    add_port_arguments(perform)
    add_network_arguments(perform)
    perform.set_defaults(handler=run_perform)

    show = subparsers.add_parser(
        "show",
        help="conduct a show: several robots (each running choreo perform) dance together",
        description="Find every performer the show file names, measure their clocks, stage "
        "and preflight every part, start them all on one instant with the song, and follow "
        "them. Ctrl-C stops every performer.",
    )
    show.add_argument("show", type=file_path, metavar="SHOW.yaml", help="a show file")
    show.add_argument(
        "--report", type=file_path, metavar="FILE.json", help="also write the report as JSON"
    )
    show.add_argument(
        "--dry-run",
        action="store_true",
        help="find, measure, stage and preflight every part, then release them: nothing moves",
    )
    show.add_argument(
        "--wait",
        type=float_in(0, MAX_WAIT_S, " s"),
        default=10.0,
        metavar="S",
        help="how long to wait for every performer to appear (default 10 s)",
    )
    show.add_argument(
        "--go",
        action="store_true",
        help="start as soon as every part is armed (for scripts); without it, the status table "
        "is shown and the show starts on Enter",
    )
    show.add_argument("--no-audio", action="store_true", help="do not play the show's song")
    show.add_argument("--audio-device", metavar="NAME", help="audio output for the song")
    add_network_arguments(show)
    show.set_defaults(handler=run_show)


def performer_name(text: str) -> str:
    if not is_name(text):
        raise argparse.ArgumentTypeError(f"a name has only {NAME_RULE}, got {text!r}")
    return text


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    network = parser.add_argument_group(
        "network (default: find each other by multicast scouting on the LAN)"
    )
    network.add_argument(
        "--zenoh-config",
        type=file_path,
        metavar="FILE",
        help="Zenoh's configuration file (JSON5): mode, TLS, user/password, access control "
        "(default: $ZENOH_CONFIG, else a peer with Zenoh's defaults); see docs/shows.md",
    )
    network.add_argument(
        "--realm",
        type=performer_name,
        default="default",
        metavar="NAME",
        help="the show's realm: conductor and performers of one realm only hear each other, so "
        "two shows on one network never mix (default: default)",
    )
    network.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="accept sessions on this Zenoh endpoint, e.g. tcp/0.0.0.0:7447 (repeatable); "
        "with --listen or --connect, only the endpoints named are used: no scouting",
    )
    network.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="connect to this Zenoh endpoint: the conductor's or a router's, e.g. "
        "tcp/192.168.1.10:7447 (repeatable)",
    )


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# --- choreo perform --------------------------------------------------------------------------
@loads(
    "choreo.bus.servo_bus", "choreo.show.performer", "choreo.show.network", "choreo.play.robot_bus"
)
def run_perform(args: argparse.Namespace) -> int:
    from choreo.bus.servo_bus import ServoBus
    from choreo.show.performer import Performer

    name = args.name or name_from(socket.gethostname().split(".")[0])
    port = bus_settings(args).port
    if port is not None:  # a port that does not open is found now, not at the show
        ServoBus(port).close()
    transport = port or "the robot file's port, else an emulated bus"
    with stop_signals_as_ctrl_c(), _network(args) as network:
        if network.exposure:
            _say(f"choreo: warning: {network.exposure}")
        performer = Performer(
            network,
            name,
            lambda robot: _open_bus(args, robot),
            transport,
            lambda text: _say(f"{name}: {text}"),
            args.max_silence_ms / 1000,
        )
        print(f"performing as {name} on {transport}: waiting for a show", flush=True)
        performer.serve_forever()
    return 0


def _network(args: argparse.Namespace):
    from choreo.show.network import Network

    return Network(args.listen, args.connect, zenoh_config=args.zenoh_config, realm=args.realm)


def _open_bus(args: argparse.Namespace, robot: Robot) -> ServoBus:
    from choreo.play.robot_bus import open_robot_bus

    settings = bus_settings(args, robot)
    if settings.port is None:
        say_built_in_emulator(robot, "performing on")
    return open_robot_bus(robot, None, settings)


# --- choreo show -----------------------------------------------------------------------------
@loads(
    "rich.console",
    "rich.progress",
    "rich.table",
    "choreo.show.conductor",
    "choreo.show.network",
    "choreo.show.showfile",
    "choreo.validate",
    "choreo.play.report",
    "choreo.music.decode",
    "choreo.play.soundtrack",
)
def run_show(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn

    from choreo.show.conductor import ConductorOptions

    show = _checked_show(args)
    options = ConductorOptions(wait_s=args.wait, dry_run=args.dry_run)
    sink, song = (None, None) if args.no_audio or args.dry_run else _open_song(args, show)

    cued: list[float] = []  # with cues, the song starts with the first only

    def cue_song(start_s: float) -> None:
        if sink is not None and song is not None and show.music is not None and not cued:
            sink.play(song, show.music.start_s, time.monotonic() + start_s - time.time())
            cued.append(start_s)

    console = Console(stderr=True)
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[at]}"))
    try:
        with (
            stop_signals_as_ctrl_c(),  # SIGTERM is Ctrl-C: every performer stops, a report
            _network(args) as network,
            Progress(*columns, console=console) as progress,
        ):
            reports = _run_cues(args, show, network, progress, options, cue_song)
    finally:
        if sink is not None:
            sink.stop()
    _write_and_print(args, show, reports)
    if reports[-1].interrupted:
        return 130
    return 0 if len(reports) == len(show.in_cues()) and reports[-1].completed else 1


def _checked_show(args: argparse.Namespace) -> Show:
    """The show file, once every motion in it plans and its report can be written."""
    from choreo.show.showfile import load_show
    from choreo.validate import check_file  # plans every motion: only when a show runs

    problems = check_file(args.show, physics=False).problems  # every motion, before any robot
    if problems:
        raise ChoreoError(
            f"refusing to start the show: {len(problems)} problem(s) in its files:\n  "
            + "\n  ".join(problems)
        )
    show = load_show(args.show)
    if args.report is not None:
        check_writable(args.report)
    return show


def _run_cues(args, show, network, progress, options, cue_song) -> list:
    """Each cue in turn, armed and started on GO; a cue that did not complete ends the show."""
    from choreo.show.conductor import Conductor

    reports = []
    for cue in show.in_cues():
        tasks = {
            p.performer: progress.add_task(p.performer, total=1.0, at="waiting") for p in cue.parts
        }

        def on_progress(p, tasks=tasks) -> None:
            if p.performer in tasks:
                done = max(0.0, p.time_s) / p.duration_s if p.duration_s > 0 else 1.0
                at = f"{p.time_s:6.1f}/{p.duration_s:.1f} s"
                progress.update(tasks[p.performer], completed=done, at=at)

        def on_armed(armed, cue=cue) -> None:
            progress.console.print(_status_table(cue.name, armed))
            if not args.go:
                _wait_for_go(progress)

        conductor = Conductor(network, cue, progress.console.print, options)
        reports.append(conductor.run(on_progress, cue_song, on_armed))
        if not reports[-1].completed:
            break
    return reports


def _wait_for_go(progress: Progress) -> None:
    progress.stop()  # the live bars would write over the prompt
    try:
        _say("armed: press Enter for GO (Ctrl-C calls the show off)")
        input()
    except EOFError:
        raise ChoreoError(
            "no GO: the input ended before Enter; give --go to start without one"
        ) from None
    progress.start()


def _write_and_print(args: argparse.Namespace, show: Show, reports: list) -> None:
    from choreo.play.report import write_report

    if args.report is not None:
        documents = [report_document(report) for report in reports]
        write_report(
            args.report,
            documents[0] if not show.cues else {"show": show.name, "cues": documents},
        )
    for report in reports:
        _print_report(report)


def _status_table(title: str, armed) -> Table:
    from rich.table import Table

    table = Table(title=f"{title}: armed")
    for column in ("performer", "robot", "health", "clock offset", "preflight", "part"):
        table.add_column(column)
    for a in armed:
        health = f"unchecked: {', '.join(a.unchecked)}" if a.unchecked else "ok"
        part = f"{a.approach_s:.1f} s approach, {a.duration_s:.1f} s part"
        table.add_row(a.performer, a.robot, health, a.clock.describe(), "passed", part)
    return table


def _open_song(args: argparse.Namespace, show: Show):
    from choreo.music.decode import decode_song
    from choreo.play.soundtrack import OUTPUT_RATE_HZ, NoAudioOutput, SoundDeviceSink

    if show.music is None:
        return None, None
    try:
        song = decode_song(show.music.song, rate_hz=OUTPUT_RATE_HZ, channels=2)
        return SoundDeviceSink(args.audio_device), song
    except NoAudioOutput as error:
        _say(f"choreo: no audio output: {error}; the show goes on without the music")
        return None, None


def report_document(report) -> dict:
    spread = report.first_start_spread_s()
    return {
        "show": report.show,
        "start_s": report.start_s,
        "time_to_start_s": report.start_s - report.called_at_s if report.start_s else None,
        "first_start_spread_ms": None if spread is None else spread * 1000,
        "stop_sent_s": report.stop_sent_s,
        "stop_reason": report.stop_reason,
        "performers": [
            {
                "name": p.performer,
                "robot": p.robot,
                "outcome": p.outcome.value,
                "reason": p.reason,
                "clock_offset_ms": p.clock.offset_s * 1000,
                "clock_offset_error_ms": p.clock.error_s * 1000,
                "clock_drift_ms": None if p.drift_s is None else p.drift_s * 1000,
                "offset_s": p.offset_s,
                "first_start_s": None if p.finished is None else p.finished.first_start_s,
                "first_start_conductor_s": p.first_start_s,
                "approach_start_s": None if p.finished is None else p.finished.approach_start_s,
                "stop_s": None if p.finished is None else p.finished.stop_s,
                "stop_written_s": None if p.finished is None else p.finished.stop_written_s,
                "stop_cause": None
                if p.finished is None or p.finished.stop_cause is None
                else p.finished.stop_cause.value,
                "ticks_played": None if p.finished is None else p.finished.ticks_played,
                "ticks_total": None if p.finished is None else p.finished.ticks_total,
                "lateness_p99_ms": None if p.finished is None else p.finished.lateness_p99_ms,
                "first_start_late_ms": None
                if p.finished is None
                else p.finished.first_start_late_ms,
            }
            for p in report.parts
        ],
    }


def _print_report(report) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    table = Table(title=f"show {report.show}")
    columns = ("performer", "robot", "outcome", "clock offset", "drift", "first START", "reason")
    for column in columns:
        table.add_column(column)
    for p in report.parts:
        first = (
            f"{(p.first_start_s - report.start_s - p.offset_s) * 1000:+.2f} ms"
            if p.first_start_s is not None
            else "-"
        )
        drift = "-" if p.drift_s is None else f"{p.drift_s * 1000:+.2f} ms"
        table.add_row(
            p.performer, p.robot, p.outcome.value, p.clock.describe(), drift, first, p.reason
        )
    console.print(table)
    spread = report.first_start_spread_s()
    if spread is not None:
        console.print(
            f"first START spread across performers: {spread * 1000:.3f} ms (each read from its "
            "performer's clock when the START was written, less its measured offset)"
        )
