"""``choreo preview``: simulate a motion as the servos will play it, check it, render it."""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from ..motion import load_motion
from ..music import check_speed
from .arguments import add_planning_arguments, positive_float, positive_int

OUTPUT_SUFFIXES = (".mp4", ".gif", ".png")


def register(subparsers) -> None:
    preview = subparsers.add_parser(
        "preview",
        help="simulate a motion in MuJoCo: check it and render it",
        description="Play the motion's ticks (what the servos will receive) to a MuJoCo model of "
        "the robot whose actuators behave like the servos (lag, torque limit), then "
        "report self-collisions, floor contact, joint limit hits, stalls, tracking "
        "errors and falls. -o renders offscreen (no display or GPU needed): .mp4, "
        ".gif, or .png for a contact sheet. Without -o or --viewer only the checks "
        "run; they exit 1 if any finds an error.",
    )
    preview.add_argument("motion", type=Path, metavar="MOTION", help="a motion .yaml file")
    preview.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="FILE",
        help="render to FILE: .mp4, .gif, or .png (a contact sheet)",
    )
    preview.add_argument(
        "--check",
        action="store_true",
        help="only run the checks (no rendering); exit 1 on any error",
    )
    preview.add_argument(
        "--report",
        type=Path,
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
        "--fps", type=positive_float, help="frames per second (default 30 for mp4, 25 for gif)"
    )
    preview.add_argument(
        "--frames",
        type=positive_int,
        default=12,
        metavar="N",
        help="frames in a png contact sheet (default 12)",
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
        help="report a servo at its torque limit this long as a stall (default 0.25 s)",
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
        type=positive_float,
        default=0.5,
        metavar="FRACTION",
        help="... or below this fraction of its starting height (default 0.5)",
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


def image_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)[xX](\d+)", text.strip())
    if not match or min(int(match[1]), int(match[2])) < 16:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT of at least 16x16, e.g. 640x480, got {text!r}"
        )
    return int(match[1]), int(match[2])


def _usage_error(message: str) -> int:
    print(f"choreo preview: error: {message}", file=sys.stderr)
    return 2


def run_preview(args: argparse.Namespace) -> int:
    output: Path | None = args.output
    if output is not None and output.suffix.lower() not in OUTPUT_SUFFIXES:
        return _usage_error(f"-o {output}: the file must end in {', '.join(OUTPUT_SUFFIXES)}")
    if (
        output is not None
        and output.suffix.lower() == ".mp4"
        and (args.size[0] % 2 or args.size[1] % 2)
    ):
        return _usage_error(
            f"--size {args.size[0]}x{args.size[1]}: mp4 needs an even width and height"
        )
    if args.check and (output is not None or args.viewer):
        return _usage_error("--check runs the checks only: drop -o and --viewer, or --check")

    from .. import preview  # imports mujoco: only when this command runs

    motion = load_motion(args.motion)
    if output is not None and output.suffix.lower() == ".mp4":
        check_speed(motion.music, args.speed, "drop --speed for a video with the song")
    thresholds = preview.CheckThresholds(
        max_tracking_error_deg=args.max_tracking_error,
        stall_after_s=args.stall_after,
        fall_tilt_deg=args.fall_tilt,
        fall_height_fraction=args.fall_height,
    )
    settings = preview.SimSettings(move_start=preview.MoveStart(args.move_start))
    rollout = preview.simulate_motion(
        motion, settings, speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance
    )
    results = preview.run_checks(rollout, thresholds)
    for result in results:
        print(f"{args.motion}: {result.severity.value}: {result.message}")
    errors = sum(r.severity is preview.Severity.ERROR for r in results)
    print(
        f"{args.motion}: {rollout.duration_s:.2f} s simulated, {errors} error(s), "
        f"{len(results) - errors} warning(s)"
    )

    if args.report is not None:
        report = preview.preview_report(rollout, results, motion=str(args.motion))
        args.report.write_text(json.dumps(report, indent=2, ensure_ascii=False) + "\n")
        print(f"wrote {args.report}")
    if output is not None:
        settings = preview.RenderSettings(
            width=args.size[0],
            height=args.size[1],
            fps=args.fps,
            sheet_frames=args.frames,
            high_quality=args.hq,
        )
        done = _render_with_progress(preview, rollout, output, settings, results, motion)
        print(
            f"wrote {output} ({done.frames} frames of {args.size[0]}x{args.size[1]}, "
            f"rendered with {done.backend})"
        )
    if args.viewer:
        preview.show_in_viewer(rollout)
    rendering = output is not None or args.viewer
    return 1 if errors and not rendering else 0


def _render_with_progress(preview, rollout, output: Path, settings, results, motion):
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

        return preview.render_preview(
            rollout, output, settings, results, on_frame=on_frame, music=motion.music
        )
