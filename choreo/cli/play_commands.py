"""``choreo play``: preflight, approach, stream, report."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn
from rich.table import Table

from choreo.bus import transports
from choreo.cli.arguments import (
    add_planning_arguments,
    add_port_arguments,
    bus_settings,
    file_path,
    load_dance,
    number_in,
    positive_int,
    say_built_in_emulator,
    stop_signals_as_ctrl_c,
)
from choreo.core.atomic import check_writable
from choreo.errors import UsageError
from choreo.motion.motion_file import HOME_POSE, Motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.dry_run import schedule
from choreo.play.play_motion import check_options, play_motion, prepared_motion
from choreo.play.play_options import AUDIO_LATENCY_S, HEALTH_TIMEOUT_S, ExitMode, PlayOptions
from choreo.play.report import Outcome, PlayProgress, PlayReport, report_document, write_report
from choreo.play.soundtrack import AudioSink, SongCue, SoundDeviceSink

EXIT_CODES = {Outcome.COMPLETED: 0, Outcome.ABORTED: 1, Outcome.INTERRUPTED: 130}


def register(subparsers) -> None:
    play = subparsers.add_parser(
        "play",
        help="play a motion on the servos (default: the built-in emulated bus)",
        description="Check every servo, approach the first pose slowly, then stream the motion: "
        "each tick is staged on the servos and started by one broadcast MOVE_START (through a "
        "controller board that cannot stage: one move frame per tick). "
        "Ctrl-C stops the servos at once.",
    )
    play.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    add_port_arguments(play)
    play.add_argument(
        "--loop",
        type=positive_int,
        metavar="N",
        help="play the motion N times (overrides the file's repeat)",
    )
    play.add_argument(
        "--dry-run",
        action="store_true",
        help="plan everything, open no port, print the packet schedule",
    )
    add_planning_arguments(play)
    play.add_argument(
        "--exit",
        choices=[m.value for m in ExitMode],
        default="hold",
        help="after the motion or a stop: hold (default), go to the exit pose, unload",
    )
    play.add_argument("--exit-pose", help="pose for --exit pose (default home)")
    play.add_argument(
        "--health-timeout-ms",
        type=number_in(HEALTH_TIMEOUT_S.scaled(1000, " ms")),
        default=20.0,
        metavar="MS",
        help="timeout of the health reads made between ticks (default 20 ms; raise "
        "it for USB adapters with a long latency timer)",
    )
    play.add_argument(
        "--report",
        type=file_path,
        metavar="FILE.json",
        help="also write the report as JSON (outcome, timing, bytes, health per servo; "
        "on the emulator the path error against the plan)",
    )
    music = play.add_argument_group("music (for a motion with a music: block)")
    music.add_argument("--no-audio", action="store_true", help="play without the song")
    music.add_argument(
        "--audio-device",
        metavar="NAME",
        help="audio output to play the song on (default: the system's)",
    )
    music.add_argument(
        "--audio-latency-ms",
        type=number_in(AUDIO_LATENCY_S.scaled(1000, " ms")),
        metavar="MS",
        help="the output's latency to make up for, instead of what the device reports "
        "(raise it if the song comes late, e.g. on Bluetooth speakers)",
    )
    play.set_defaults(handler=run_play)


def run_play(args: argparse.Namespace) -> int:
    if args.exit_pose is not None and args.exit != ExitMode.POSE.value:
        raise UsageError(
            f"--exit-pose {args.exit_pose} is used only with --exit pose (now --exit "
            f"{args.exit}): add --exit pose, or drop --exit-pose"
        )
    exit_pose = args.exit_pose or HOME_POSE
    if args.report is not None:
        if args.dry_run:
            raise UsageError("--report needs a play; --dry-run plays nothing")
        check_writable(args.report)
    options = PlayOptions(
        exit_mode=ExitMode(args.exit),
        exit_pose=exit_pose,
        tolerance_deg=args.tolerance,
        health_timeout_s=args.health_timeout_ms / 1000,
        speed=args.speed,
        stretch=args.stretch,
        loop=args.loop,
        audio=not args.no_audio,
        audio_device=args.audio_device,
        audio_latency_s=None if args.audio_latency_ms is None else args.audio_latency_ms / 1000,
        allow_past_song=args.allow_past_song,
    )
    motion = load_dance(args.motion, args.allow_past_song)
    check_options(motion, options)  # before the port opens and the progress bar shows
    settings = bus_settings(args, motion.robot)
    if args.dry_run:
        return dry_run(prepared_motion(motion, options, _note), options, settings.port)
    if settings.port is None:
        say_built_in_emulator(motion.robot, "playing on")
    with stop_signals_as_ctrl_c(), _progress_bar() as on_progress:
        report = play_motion(
            motion,
            options=options,
            bus_settings=settings,
            open_audio=lambda device, latency_s: open_audio_output(device, latency_s),
            on_progress=on_progress,
            on_note=_note,
        )
    if args.report is not None:  # before printing: a closed stdout pipe must not lose it
        write_report(args.report, report_document(report))
    _print_report(report)
    exit_move = report.exit_move
    if exit_move is not None and exit_move.outcome is not Outcome.COMPLETED:
        _note(
            f"the move to the exit pose {exit_pose!r} {exit_move.outcome.value}: {exit_move.reason}"
        )
    return EXIT_CODES[report.outcome]


def _note(text: str) -> None:
    print(text, file=sys.stderr)


def open_audio_output(device: str | None, latency_s: float | None) -> AudioSink:
    """The real output (tests put a recording sink here)."""
    return SoundDeviceSink(device, latency_s)


@contextlib.contextmanager
def _progress_bar() -> Iterator[Callable[[PlayProgress], None]]:
    """A progress bar on stderr, and the callback that moves it. The bar appears with the first
    progress, once the servos move: a motion refused before (a dance past its song, a port that
    does not open) shows its one line alone, not under an "approach" bar that never moved."""
    console = Console(stderr=True)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
    )
    with contextlib.ExitStack() as shown:
        bar: list[tuple[Progress, TaskID]] = []
        last_refresh = [0.0]

        def update(p: PlayProgress) -> None:
            if not bar:
                # No auto-refresh: its thread would take the GIL at random moments and make
                # STARTs late. The player calls ``update`` right after a START, in the time set
                # aside for the bus.
                progress = shown.enter_context(
                    Progress(*columns, console=console, auto_refresh=False)
                )
                bar.append((progress, progress.add_task(p.stage, total=None, status="")))
            progress, task = bar[0]
            progress.update(
                task,
                description=p.stage,
                total=p.ticks,
                completed=p.tick,
                status=f"{p.time_s:6.2f}/{p.duration_s:.2f} s  bus {p.bus_use:4.0%}",
            )
            if p.time_s - last_refresh[0] >= 0.1 or p.tick == p.ticks:
                last_refresh[0] = p.time_s
                progress.refresh()

        yield update


def _print_report(report: PlayReport) -> None:
    path_errors = report.path_errors_deg
    console = Console()
    verdict = {
        Outcome.COMPLETED: "[green]completed[/]",
        Outcome.INTERRUPTED: "[yellow]stopped[/]",
        Outcome.ABORTED: "[red]aborted[/]",
    }[report.outcome]
    console.print(f"{verdict} {report.reason}".rstrip())
    console.print(
        f"ticks {report.ticks_played}/{report.ticks_total}, re-targeted {report.retargeted}; "
        f"START lateness p50 {report.lateness_percentile_ms(50):.2f} ms, "
        f"p99 {report.lateness_percentile_ms(99):.2f} ms, "
        f"max {max(report.lateness_ms, default=0):.2f} ms; "
        f"end {report.end_error_ms:+.1f} ms from schedule; {report.bytes_sent} bytes, "
        f"bus use {report.bus_use:.0%}, {report.missed_reads} health reads missed"
    )
    if report.start_skew_ms:
        console.print(
            f"transport {report.transport}: no staged start, each tick is one move frame the "
            f"board forwards servo by servo: first-to-last start skew {report.start_skew_ms:.1f} ms"
        )
    table = Table(title="servo health")
    for column in ("joint", "id", "temp °C", "vin V", "max pos err °", "path err °"):
        table.add_column(column, justify="right")
    for index, h in enumerate(report.health):
        temps = f"{h.temp_c_min}..{h.temp_c_max}" if h.temp_c_min is not None else "-"
        vins = (
            f"{h.vin_mv_min / 1000:.2f}..{h.vin_mv_max / 1000:.2f}"
            if h.vin_mv_min and h.vin_mv_max is not None  # both are set by the same read
            else "-"
        )
        pos = f"{h.position_error_deg_max:.2f}" if h.position_error_deg_max is not None else "-"
        path = f"{path_errors[index]:.2f}" if path_errors else "-"
        table.add_row(h.joint, str(h.servo_id), temps, vins, pos, path)
    console.print(table)


def dry_run(motion: Motion, options: PlayOptions, port: str | None) -> int:
    """Print every packet (through a board: every move frame) with its time, and when the song
    starts."""
    compiled = compile_motion(motion, options.plan)
    for stretch in compiled.stretches:
        _note(stretch.describe())
    link = transports.link(port)
    music = motion.music if options.audio else None
    robot = compiled.robot
    performance = prepare(compiled, robot.pose_vector(HOME_POSE))
    print(f"dry run: no port opened; the approach starts from {robot.name}'s home pose")
    if not link.capabilities.staged_start:
        print(
            f"through the {link.capabilities.transport}: no staging, one move frame per tick, "
            "forwarded one servo at a time"
        )
    packets = schedule(performance.ticks, robot, link)
    cue = SongCue.of(music, performance) if music is not None else None
    song_ms = round(max(0.0, -cue.from_s) * 1000) if cue else None
    for packet in packets:
        if cue and song_ms is not None and packet.time_ms > song_ms:
            print(f"{song_ms:8d} ms  {cue.describe()}")
            song_ms = None
        print(f"{packet.time_ms:8d} ms  {packet.packet.hex(' ')}  {packet.description}")
    if cue and song_ms is not None:
        print(f"{song_ms:8d} ms  {cue.describe()}")
    total = sum(len(p.packet) for p in packets)
    print(
        f"{len(performance.ticks)} ticks over {performance.ticks[-1].end_ms / 1000:.3f} s, "
        f"{total} bytes"
        if performance.ticks
        else "nothing to play"
    )
    return 0
