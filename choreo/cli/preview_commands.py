"""``choreo preview``: simulate a motion as the servos will play it, check it, render it."""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import re
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from choreo.cli import in_flags, report_in_flags, restore_mujoco_gl
from choreo.cli.arguments import (
    add_planning_arguments,
    ctrl_c_deferred,
    file_path,
    load_dance,
    plan_options,
    positive_float,
    positive_int,
    stop_signals_as_ctrl_c,
)
from choreo.core.atomic import atomic_output, check_writable, write_text_atomically
from choreo.errors import UsageError
from choreo.motion.music_block import check_speed
from choreo.motion.scene import StartPosture
from choreo.validate import heading_for

OUTPUT_SUFFIXES = (".mp4", ".gif", ".png")


# One statement per flag, in the order --help lists them: a long function, kept whole so that a
# command's usage reads top to bottom in one place.
def register(subparsers) -> None:
    preview = subparsers.add_parser(
        "preview",
        help="simulate a motion in MuJoCo: check it and render it",
        description="Start the robot at rest in its start pose (a walking robot put down on the "
        "floor and settled), play the player's approach and then the motion's ticks (what "
        "the servos will receive) to a MuJoCo model of the robot whose actuators behave like "
        "the servos (lag, torque limit, supply, dead band, backlash), then report "
        "self-collisions, floor contact, overlapping neighbours, joint limit hits, stalls, "
        "lag, near misses, tracking errors and falls. -o renders offscreen (no display or GPU "
        "needed): .mp4, .gif, or .png for a contact sheet. Without -o or --viewer only the "
        "checks run; they exit 1 if any finds an error. See docs/preview.md.",
    )
    preview.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    preview.add_argument(
        "-o",
        "--output",
        type=file_path,
        metavar="FILE",
        help="render to FILE: .mp4, .gif, or .png (a contact sheet)",
    )
    preview.add_argument(
        "--overwrite", action="store_true", help="replace an existing FILE given with -o"
    )
    preview.add_argument(
        "--check",
        action="store_true",
        help="only run the checks (no rendering); exit 1 on any error",
    )
    preview.add_argument(
        "--report",
        type=file_path,
        metavar="FILE.json",
        help="write every check result and per-joint peaks as JSON",
    )
    preview.add_argument(
        "--viewer", action="store_true", help="open MuJoCo's interactive viewer (needs a display)"
    )
    preview.add_argument(
        "--size",
        type=image_size,
        default=(640, 480),
        metavar="WxH",
        help="frame size in pixels (default 640x480; contact sheet: per frame)",
    )
    preview.add_argument(
        "--fps",
        type=positive_float,
        help=f"frames per second: mp4 up to {MAX_VIDEO_FPS:g} (default 30); gif 100/N, as its "
        "frame delays are whole 10 ms and browsers slow delays under 20 ms: 50, 33.33, 25 "
        "(default), 20, ...",
    )
    preview.add_argument(
        "--frames",
        type=sheet_frames,
        default=12,
        metavar="N",
        help=f"frames in a png contact sheet, 1-{MAX_SHEET_FRAMES} (default 12)",
    )
    preview.add_argument(
        "--hq",
        action="store_true",
        help="shadows, reflections and anti-aliasing (several times slower)",
    )
    add_planning_arguments(preview)
    preview.add_argument(
        "--max-tracking-error",
        type=positive_float,
        default=10.0,
        metavar="DEG",
        help="report a joint this far off its commanded path (default 10°)",
    )
    preview.add_argument(
        "--stall-after",
        type=positive_float,
        default=0.25,
        metavar="S",
        help="report a servo at its torque limit and barely moving this long as a stall, and "
        "one at its limit while moving this long as lagging (default 0.25 s)",
    )
    preview.add_argument(
        "--near-miss",
        type=fraction,
        default=0.8,
        metavar="FRACTION",
        help="warn of a servo working at this share of its stall torque or more for 0.1 s "
        "(default 0.8)",
    )
    preview.add_argument(
        "--fall-tilt",
        type=positive_float,
        default=30.0,
        metavar="DEG",
        help="a free-floating body tilted this far has fallen (default 30°)",
    )
    preview.add_argument(
        "--fall-height",
        type=fraction,
        default=0.5,
        metavar="FRACTION",
        help="... or below this fraction of its starting height (default 0.5)",
    )
    preview.add_argument(
        "--from",
        dest="start_pose",
        metavar="POSE",
        help="the pose the robot is in before the approach: a pose of the robot, or 'first' "
        "for the motion's first keyframe (default: home; first for a motion that starts lying)",
    )
    preview.add_argument(
        "--start",
        choices=["standing", "lying", "lying_front", "lying_back"],
        help="how a free-floating robot rests on the floor before the motion (default: the "
        "motion's start: key, else standing)",
    )
    preview.add_argument(
        "--move-start",
        choices=["setpoint", "position"],
        default="setpoint",
        help="where a servo's new move starts: where its own interpolation is "
        "(default), or where its shaft is (pessimistic: loaded joints sag "
        "at every tick)",
    )
    preview.set_defaults(handler=run_preview)


MAX_SIDE_PX = 8192  # 8K; the GL's own limit may be lower (then a one-line PreviewError)
MAX_SHEET_FRAMES = 100  # a 10x10 sheet; more tiles are too small to read (and take minutes)
MAX_VIDEO_FPS = 120.0  # twice any screen's usual rate; slow motion is --speed
GIF_DELAY_S = 0.01  # GIF frame delays are whole hundredths of a second
MIN_GIF_DELAYS = 2  # browsers play a delay under 20 ms as 100 ms


def sheet_frames(text: str) -> int:
    value = positive_int(text)
    if value > MAX_SHEET_FRAMES:
        raise argparse.ArgumentTypeError(
            f"expected a whole number from 1 to {MAX_SHEET_FRAMES}, got {text!r}"
        )
    return value


def checked_fps(fps: float | None, suffix: str) -> float | None:
    """``fps`` if a ``suffix`` file plays it as asked (a GIF's 100/N made exact); UsageError if
    not."""
    if fps is None or suffix == ".png":
        return fps
    if suffix == ".mp4":
        if fps > MAX_VIDEO_FPS:
            raise UsageError(
                f"--fps {fps:g}: an mp4 has at most {MAX_VIDEO_FPS:g} frames per second (slow "
                "motion: --speed 0.5)"
            )
        return fps
    delays = 1 / (fps * GIF_DELAY_S)
    if round(delays) < MIN_GIF_DELAYS or abs(delays - round(delays)) > 0.01:
        raise UsageError(
            f"--fps {fps:g}: a GIF plays 100/N frames per second (its delays are whole 10 ms, "
            "and browsers slow delays under 20 ms): 50, 33.33, 25, 20, 16.67, ..."
        )
    return 1 / (round(delays) * GIF_DELAY_S)


def image_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)[xX](\d+)", text.strip())
    if not match or not all(16 <= int(side) <= MAX_SIDE_PX for side in match.groups()):
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT from 16x16 to {MAX_SIDE_PX}x{MAX_SIDE_PX}, e.g. 640x480, "
            f"got {text!r}"
        )
    return int(match[1]), int(match[2])


def fraction(text: str) -> float:
    value = positive_float(text)
    if value > 1:
        raise argparse.ArgumentTypeError(f"expected a fraction in (0, 1], got {text!r}")
    return value


def run_preview(args: argparse.Namespace) -> int:
    # `kill` or a closed terminal stops a long render as Ctrl-C does: no temporary left behind
    with stop_signals_as_ctrl_c():
        return _preview(args)


def _preview(args: argparse.Namespace) -> int:
    output: Path | None = args.output
    fps = _checked_outputs(args)

    with ctrl_c_deferred():  # imports mujoco: only when this command runs
        from choreo import preview

    if output is not None:  # a render that cannot be is known before the simulation
        restore_mujoco_gl()  # mujoco is imported: now the back-end MUJOCO_GL names is used
        preview.gl.offscreen_backend()

    motion = load_dance(args.motion, args.allow_past_song)
    if args.start is not None:
        motion = dataclasses.replace(motion, start=StartPosture(args.start))
    if output is not None and output.suffix.lower() == ".mp4":
        check_speed(motion.music, args.speed)
    thresholds = preview.CheckThresholds(
        max_tracking_error_deg=args.max_tracking_error,
        stall_after_s=args.stall_after,
        near_miss_fraction=args.near_miss,
        fall_tilt_deg=args.fall_tilt,
        fall_height_fraction=args.fall_height,
    )
    settings = preview.SimSettings(move_start=preview.MoveStart(args.move_start))
    poses = [*motion.robot.poses, preview.FIRST_KEYFRAME]
    if args.start_pose is not None and args.start_pose not in poses:
        raise UsageError(
            f"--from {args.start_pose}: {motion.robot.name} has no such pose; "
            f"valid: {', '.join(poses)}"
        )
    simulated = preview.simulate_motion(
        motion,
        settings,
        plan=plan_options(args),
        start_pose=args.start_pose,
    )
    results = preview.run_checks(simulated, thresholds)
    errors = _print_findings(args, preview, motion, simulated, results, thresholds)
    if args.report is not None:
        report = preview.preview_report(
            simulated, results, motion=str(args.motion), thresholds=thresholds
        )
        text = json.dumps(report_in_flags(report), indent=2, ensure_ascii=False)
        write_text_atomically(args.report, text + "\n")
        print(f"wrote {args.report}")
    if output is not None:
        _render(args, preview, simulated.rollout, output, fps, results, motion)
    if args.viewer:
        preview.show_in_viewer(simulated.rollout)
    rendering = output is not None or args.viewer
    return 1 if errors and not rendering else 0


def _checked_outputs(args: argparse.Namespace) -> float | None:
    """Refuse outputs that cannot be written before anything is simulated; the frame rate."""
    output: Path | None = args.output
    if output is not None and output.suffix.lower() not in OUTPUT_SUFFIXES:
        raise UsageError(f"-o {output}: the file must end in {', '.join(OUTPUT_SUFFIXES)}")
    if (
        output is not None
        and output.suffix.lower() == ".mp4"
        and (args.size[0] % 2 or args.size[1] % 2)
    ):
        raise UsageError(
            f"--size {args.size[0]}x{args.size[1]}: mp4 needs an even width and height"
        )
    if args.check and (output is not None or args.viewer):
        raise UsageError("--check runs the checks only: drop -o and --viewer, or --check")
    fps = checked_fps(args.fps, output.suffix.lower()) if output is not None else args.fps
    if output is not None:
        check_writable(output, overwrite=args.overwrite)
    if args.report is not None:
        check_writable(args.report)
    return fps


def _print_findings(args, preview, motion, simulated, results, thresholds) -> int:
    """Print what the simulation found, line by line, and the summary; the number of errors."""
    rollout = simulated.rollout
    for line in preview.start_lines(rollout):
        print(f"{args.motion}: {in_flags(line)}")
    for result in results:
        where = heading_for(motion, rollout.keyframe_times_s, result.time_s)
        print(f"{where}: {result.severity.value}: {result.message}")
    if simulated.travel is not None:
        print(f"{args.motion}: {describe_travel(simulated.travel)}")
    for outcome in simulated.props:
        print(f"{args.motion}: {outcome.line()}")
    for gait in simulated.gaits:
        print(f"{args.motion}: {gait.line()}")
    reach = preview.reach_line(simulated)
    if reach is not None:
        print(f"{args.motion}: {reach}")
    errors = sum(r.severity is preview.Severity.ERROR for r in results)
    print(f"{args.motion}: {preview.busiest_line(rollout, thresholds.near_miss_fraction)}")
    print(
        f"{args.motion}: {rollout.duration_s:.2f} s simulated, {errors} error(s), "
        f"{len(results) - errors} warning(s)"
    )
    return errors


def _render(args, preview, rollout, output: Path, fps: float | None, results, motion) -> None:
    render_settings = preview.RenderSettings(
        width=args.size[0],
        height=args.size[1],
        fps=fps,
        sheet_frames=args.frames,
        high_quality=args.hq,
    )
    done = _render_with_progress(preview, rollout, output, render_settings, results, motion)
    print(
        f"wrote {output} ({done.frames} frames of {args.size[0]}x{args.size[1]}, "
        f"rendered with {done.backend})"
    )


def describe_travel(travel) -> str:
    """One line: where a free-floating robot's body went."""
    x0, y0, _ = (round(v) + 0 for v in travel.start_mm)  # + 0: no "-0"
    x1, y1, _ = (round(v) + 0 for v in travel.end_mm)
    return (
        f"{travel.body} went from ({x0}, {y0}) mm heading {round(travel.start_heading_deg) + 0}° "
        f"to ({x1}, {y1}) mm heading {round(travel.end_heading_deg) + 0}°: "
        f"{travel.displacement_mm:.0f} mm away ({travel.path_mm:.0f} mm along its path), "
        f"turned {round(travel.turned_deg) + 0:+d}°"
    )


def _render_with_progress(preview, rollout, output: Path, settings, results, motion):
    # imageio_ffmpeg warns "the written video is invalid" when stopped: the temporary is
    # removed anyway, and an error reaches the user as one line
    logging.getLogger("imageio_ffmpeg").setLevel(logging.ERROR)
    console = Console(stderr=True)
    columns = (
        TextColumn("rendering {task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, transient=True) as progress:
        task = progress.add_task(output.name, total=None)

        def on_frame(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        # rendered beside it and renamed at the end: Ctrl-C or a failure keeps an older file
        with atomic_output(output) as temporary:
            return preview.render_preview(
                rollout, temporary, settings, results, on_frame=on_frame, music=motion.music
            )
