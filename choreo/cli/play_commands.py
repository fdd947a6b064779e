"""``choreo play``: preflight, approach, stream, report."""

from __future__ import annotations

import argparse
import bisect
import dataclasses
import sys
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..atomic import check_writable
from ..audio import Audio
from ..clock import RealClock
from ..emulator.trace import start_skew_ms
from ..errors import UsageError
from ..motion import load_motion, too_many_played
from ..music import Music, check_speed
from ..path_errors import measured_path_errors
from ..pipeline import CompiledMotion, compile_motion
from ..play_report import report_document, transport_of, write_report
from ..player import (
    ExitMode,
    Outcome,
    Performance,
    Player,
    PlayOptions,
    PlayReport,
    frame_schedule,
    packet_schedule,
    preflight,
    prepare,
    unchecked,
)
from ..robot import MAX_TIMEOUT_MS, Robot
from ..soundtrack import (
    AudioSink,
    NoAudioOutput,
    SongCue,
    SoundDeviceSink,
    play_with_song,
    song_for_output,
)
from ..transports import board_module
from .arguments import (
    add_planning_arguments,
    add_port_arguments,
    bus_settings,
    float_in,
    open_robot_bus,
    positive_int,
    stop_signals_as_ctrl_c,
)

MAX_AUDIO_LATENCY_MS = 2000.0  # Bluetooth speakers reach a few hundred ms; seconds is a mistake
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
    play.add_argument("motion", type=Path, metavar="MOTION", help="a motion .yaml file")
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
    play.add_argument("--exit-pose", default="home", help="pose for --exit pose (default home)")
    play.add_argument(
        "--health-timeout-ms",
        type=float_in(0, MAX_TIMEOUT_MS, " ms"),
        default=20.0,
        metavar="MS",
        help="timeout of the health reads made between ticks (default 20 ms; raise "
        "it for USB adapters with a long latency timer)",
    )
    play.add_argument(
        "--report",
        type=Path,
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
        type=float_in(0, MAX_AUDIO_LATENCY_MS, " ms"),
        metavar="MS",
        help="the output's latency to make up for, instead of what the device reports "
        "(raise it if the song comes late, e.g. on Bluetooth speakers)",
    )
    play.set_defaults(handler=run_play)


def run_play(args: argparse.Namespace) -> int:
    motion = load_motion(args.motion)
    if not args.no_audio:
        check_speed(motion.music, args.speed, "drop --speed, or play without the song: --no-audio")
    if args.loop:
        unrolled = too_many_played(len(motion.keyframes), args.loop, "--loop")
        if unrolled is not None:
            raise UsageError(unrolled)
        motion = dataclasses.replace(motion, repeat=args.loop)
    robot = motion.robot
    if args.exit_pose not in robot.poses:
        raise UsageError(
            f"--exit-pose {args.exit_pose!r} is not a pose of {robot.name}; "
            f"poses: {', '.join(robot.poses)}"
        )
    if args.report is not None:
        if args.dry_run:
            raise UsageError("--report needs a play; --dry-run plays nothing")
        check_writable(args.report)
    compiled = compile_motion(
        motion, speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance
    )
    for stretch in compiled.stretches:  # said before anything moves
        print(
            f"{stretch.where}: stretched: reached {stretch.shift_s:.3f} s later than written",
            file=sys.stderr,
        )
    if args.dry_run:
        return dry_run(
            compiled,
            board_module(bus_settings(args, robot).port),
            None if args.no_audio else motion.music,
        )
    options = PlayOptions(
        exit_mode=ExitMode(args.exit),
        exit_pose=args.exit_pose,
        tolerance_deg=args.tolerance,
        health_timeout_s=args.health_timeout_ms / 1000,
    )
    bus, emulator = open_robot_bus(args, robot, doing="playing on")
    # a sim:// URL's own emulator: its clock (clock=virtual must drive the player too, or the
    # servos never move in time) and its log (the path errors)
    emulator = emulator or getattr(bus.port, "emulator", None)
    clock = emulator.clock if emulator is not None else RealClock()
    with stop_signals_as_ctrl_c(), bus:
        missing = unchecked(bus)
        if missing:
            print(
                f"note: the {bus.capabilities.transport} cannot read the servos' "
                f"{', '.join(missing)}: not checked",
                file=sys.stderr,
            )
        start_pose, limits = preflight(bus, robot)
        performance = prepare(compiled, start_pose)
        sink, song = _open_audio(args, motion.music)
        if sink is not None:  # the stream needs its latency before the first START
            options = dataclasses.replace(
                options, lead_s=max(options.lead_s, sink.latency_s + 0.05)
            )
        cue = SongCue.of(motion.music, performance) if motion.music and sink else None
        report, exit_move = _play_with_progress(
            bus, robot, clock, limits, options, performance, start_pose, (sink, song, cue)
        )
        errors = skew_ms = None
        if emulator is not None:
            errors = measured_path_errors(
                emulator.log.moves, robot, performance, report, start_pose
            )
            end_s = report.start_time_s + report.elapsed_s
            skew_ms = start_skew_ms(emulator.log.moves, report.start_time_s, end_s)
    if args.report is not None:  # before printing: a closed stdout pipe must not lose it
        document = report_document(
            report,
            motion=str(args.motion),
            robot=robot.name,
            transport=transport_of(bus.name, report),
            measured_start_skew_ms=skew_ms,
            path_errors_deg=errors,
        )
        write_report(args.report, document)
    _print_report(report, robot, errors)
    if exit_move is not None and exit_move.outcome is not Outcome.COMPLETED:
        print(
            f"the move to the exit pose {args.exit_pose!r} {exit_move.outcome.value}: "
            f"{exit_move.reason}",
            file=sys.stderr,
        )
    return EXIT_CODES[report.outcome]


def _open_audio(args, music: Music | None) -> tuple[AudioSink | None, Audio | None]:
    """The audio output and the song for it; without one, one line and the dance goes on."""
    if music is None or args.no_audio:
        return None, None
    latency_s = None if args.audio_latency_ms is None else args.audio_latency_ms / 1000
    try:
        song = song_for_output(music)
        return open_audio_output(args.audio_device, latency_s), song
    except NoAudioOutput as error:
        print(f"choreo: no audio output: {error}; playing without the music", file=sys.stderr)
        return None, None


def open_audio_output(device: str | None, latency_s: float | None) -> AudioSink:
    """The real output (tests put a recording sink here)."""
    return SoundDeviceSink(device, latency_s)


def _play_with_progress(
    bus, robot, clock, limits, options, performance: Performance, start_pose, soundtrack
) -> tuple[PlayReport, PlayReport | None]:
    """The play's report and that of the move to the exit pose (None: no such move)."""
    keyframes = [performance.approach_s + t for t in performance.trajectory.keyframe_times_s]
    console = Console(stderr=True)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
    )
    # No auto-refresh: its thread would take the GIL at random moments and make STARTs late.
    # The player calls ``update`` right after a START, in the time set aside for the bus.
    with Progress(*columns, console=console, auto_refresh=False) as progress:
        task = progress.add_task("approach", total=len(performance.ticks), status="")
        last_refresh = [0.0]

        def update(p) -> None:
            keyframe = bisect.bisect_right(keyframes, p.time_s)
            stage = (
                "approach"
                if p.time_s < performance.approach_s
                else f"keyframe {keyframe}/{len(keyframes)}"
            )
            progress.update(
                task,
                completed=p.tick,
                description=stage,
                status=f"{p.time_s:6.2f}/{p.duration_s:.2f} s  bus {p.bus_use:4.0%}",
            )
            if p.time_s - last_refresh[0] >= 0.1 or p.tick == p.ticks:
                last_refresh[0] = p.time_s
                progress.refresh()

        player = Player(bus, robot, clock, limits, options, on_progress=update)
        report = play_with_song(player, performance, start_pose, *soundtrack)
        exit_move = player.leave(report.outcome)
    return report, exit_move


def _print_report(report: PlayReport, robot: Robot, path_errors) -> None:
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


def dry_run(compiled: CompiledMotion, board=None, music: Music | None = None) -> int:
    """Print every packet (through a board: every move frame) with its time, and when the song
    starts."""
    robot = compiled.robot
    performance = prepare(compiled, robot.pose_vector("home"))
    print(f"dry run: no port opened; the approach starts from {robot.name}'s home pose")
    if board is None:
        schedule = packet_schedule(performance.ticks, robot)
    else:
        print(
            f"through the {board.CAPABILITIES.transport}: no staging, one move frame per tick, "
            "forwarded one servo at a time"
        )
        schedule = frame_schedule(performance.ticks, robot, board.move_frame)
    cue = SongCue.of(music, performance) if music is not None else None
    song_ms = round(max(0.0, -cue.from_s) * 1000) if cue else None
    for packet in schedule:
        if cue and song_ms is not None and packet.time_ms > song_ms:
            print(f"{song_ms:8d} ms  {cue.describe()}")
            song_ms = None
        print(f"{packet.time_ms:8d} ms  {packet.packet.hex(' ')}  {packet.description}")
    if cue and song_ms is not None:
        print(f"{song_ms:8d} ms  {cue.describe()}")
    total = sum(len(p.packet) for p in schedule)
    print(
        f"{len(performance.ticks)} ticks over {performance.ticks[-1].end_ms / 1000:.3f} s, "
        f"{total} bytes"
        if performance.ticks
        else "nothing to play"
    )
    return 0
