"""``choreo play``: preflight, approach, stream, report."""

from __future__ import annotations

import argparse
import bisect
import dataclasses
import signal
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..audio import Audio
from ..clock import RealClock
from ..emulator.trace import path_errors_deg
from ..motion import load_motion
from ..music import Music, check_speed
from ..player import (
    ExitMode,
    Outcome,
    Performance,
    Player,
    PlayOptions,
    PlayReport,
    packet_schedule,
    preflight,
    prepare,
)
from ..robot import Robot
from ..segments import CompiledMotion, compile_motion
from ..soundtrack import (
    AudioSink,
    NoAudioOutput,
    SongCue,
    SoundDeviceSink,
    play_with_song,
    song_for_output,
)
from .arguments import (
    add_planning_arguments,
    add_port_arguments,
    open_robot_bus,
    positive_float,
    positive_int,
)

EXIT_CODES = {Outcome.COMPLETED: 0, Outcome.ABORTED: 1, Outcome.INTERRUPTED: 130}


def register(subparsers) -> None:
    play = subparsers.add_parser(
        "play",
        help="play a motion on the servos (default: the built-in emulated bus)",
        description="Check every servo, approach the first pose slowly, then stream the motion: "
        "each tick is staged on the servos and started by one broadcast MOVE_START. "
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
        type=positive_float,
        default=20.0,
        metavar="MS",
        help="timeout of the health reads made between ticks (default 20 ms; raise "
        "it for USB adapters with a long latency timer)",
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
        type=non_negative_float,
        metavar="MS",
        help="the output's latency to make up for, instead of what the device reports "
        "(raise it if the song comes late, e.g. on Bluetooth speakers)",
    )
    play.set_defaults(handler=run_play)


def non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text!r}")
    return value


def run_play(args: argparse.Namespace) -> int:
    motion = load_motion(args.motion)
    if not args.no_audio:
        check_speed(motion.music, args.speed, "drop --speed, or play without the song: --no-audio")
    if args.loop:
        motion = dataclasses.replace(motion, repeat=args.loop)
    robot = motion.robot
    if args.exit_pose not in robot.poses:
        print(
            f"choreo: error: --exit-pose {args.exit_pose!r} is not a pose of {robot.name}; "
            f"poses: {', '.join(robot.poses)}",
            file=sys.stderr,
        )
        return 2
    compiled = compile_motion(
        motion, speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance
    )
    if args.dry_run:
        return dry_run(compiled, None if args.no_audio else motion.music)
    signal.signal(signal.SIGTERM, _interrupt)
    options = PlayOptions(
        exit_mode=ExitMode(args.exit),
        exit_pose=args.exit_pose,
        tolerance_deg=args.tolerance,
        health_timeout_s=args.health_timeout_ms / 1000,
    )
    bus, emulator = open_robot_bus(args, robot, doing="playing on")
    with bus:
        start_pose, limits = preflight(bus, robot)
        performance = prepare(compiled, start_pose)
        sink, song = _open_audio(args, motion.music)
        if sink is not None:  # the stream needs its latency before the first START
            options = dataclasses.replace(
                options, lead_s=max(options.lead_s, sink.latency_s + 0.05)
            )
        cue = SongCue.of(motion.music, performance) if motion.music and sink else None
        report, exit_move = _play_with_progress(
            bus, robot, limits, options, performance, start_pose, (sink, song, cue)
        )
        errors = None
        if emulator is not None:
            errors = measured_path_errors(emulator, robot, performance, report, start_pose)
    _print_report(report, robot, errors)
    if exit_move is not None and exit_move.outcome is not Outcome.COMPLETED:
        print(
            f"the move to the exit pose {args.exit_pose!r} {exit_move.outcome.value}: "
            f"{exit_move.reason}",
            file=sys.stderr,
        )
    return EXIT_CODES[report.outcome]


def measured_path_errors(
    emulator, robot: Robot, performance: Performance, report: PlayReport, start_pose
) -> tuple[float, ...]:
    """Per joint, how far the emulated servos strayed from the smooth plan (every 2 ms)."""
    times = np.arange(0.0, report.planned_s, 0.002)
    start_units = [j.to_units(a) for j, a in zip(robot.joints, start_pose)]
    return path_errors_deg(
        emulator.log.moves,
        robot,
        start_units,
        report.start_time_s,
        times,
        performance.planned_deg(times),
    )


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


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _play_with_progress(
    bus, robot, limits, options, performance: Performance, start_pose, soundtrack
) -> PlayReport:
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

        player = Player(bus, robot, RealClock(), limits, options, on_progress=update)
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
        f"p99 {report.lateness_percentile_ms(99):.2f} ms, max {max(report.lateness_ms, default=0):.2f} ms; "
        f"end {report.end_error_ms:+.1f} ms from schedule; {report.bytes_sent} bytes, "
        f"bus use {report.bus_use:.0%}"
    )
    table = Table(title="servo health")
    for column in ("joint", "id", "temp °C", "vin V", "max pos err °", "path err °"):
        table.add_column(column, justify="right")
    for index, h in enumerate(report.health):
        temps = f"{h.temp_c_min}..{h.temp_c_max}" if h.temp_c_min is not None else "-"
        vins = f"{h.vin_mv_min / 1000:.2f}..{h.vin_mv_max / 1000:.2f}" if h.vin_mv_min else "-"
        pos = f"{h.position_error_deg_max:.2f}" if h.position_error_deg_max is not None else "-"
        path = f"{path_errors[index]:.2f}" if path_errors else "-"
        table.add_row(h.joint, str(h.servo_id), temps, vins, pos, path)
    console.print(table)


def dry_run(compiled: CompiledMotion, music: Music | None) -> int:
    robot = compiled.robot
    performance = prepare(compiled, robot.pose_vector("home"))
    print(f"dry run: no port opened; the approach starts from {robot.name}'s home pose")
    cue = SongCue.of(music, performance) if music is not None else None
    song_ms = round(max(0.0, -cue.from_s) * 1000) if cue else None
    for packet in packet_schedule(performance.ticks, robot):
        if cue and song_ms is not None and packet.time_ms > song_ms:
            print(f"{song_ms:8d} ms  {cue.describe()}")
            song_ms = None
        print(f"{packet.time_ms:8d} ms  {packet.packet.hex(' ')}  {packet.description}")
    if cue and song_ms is not None:
        print(f"{song_ms:8d} ms  {cue.describe()}")
    total = sum(len(p.packet) for p in packet_schedule(performance.ticks, robot))
    print(
        f"{len(performance.ticks)} ticks over {performance.ticks[-1].end_ms / 1000:.3f} s, "
        f"{total} bytes"
        if performance.ticks
        else "nothing to play"
    )
    return 0
