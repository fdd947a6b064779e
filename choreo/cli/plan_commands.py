"""``choreo plan``: plan a motion and compile its ticks; report the figures, optionally plot."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from choreo.cli.arguments import (
    add_planning_arguments,
    file_path,
    load_dance,
    non_negative_float,
    plan_options,
)
from choreo.errors import UsageError
from choreo.plan.pipeline import compile_motion
from choreo.plan.report import plan_report


def register(subparsers) -> None:
    plan = subparsers.add_parser(
        "plan",
        help="plan a motion and compile it into servo ticks; report and plot",
        description="Time-parameterize the keyframes within every joint's velocity, "
        "acceleration and jerk limits, compile the smooth trajectory into ticks "
        "(synchronized linear servo moves, one broadcast START each) and report: "
        "duration, ticks, bytes, peak bus use, the largest deviation of the servos' "
        "path from the smooth plan, and per joint the peak velocity and acceleration "
        "against its limits. Exits 1 if the motion cannot be planned.",
    )
    plan.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    plan.add_argument("--json", action="store_true", help="print the report as JSON")
    plan.add_argument(
        "--plot",
        type=png_path,
        metavar="FILE.png",
        help="draw position and velocity per joint: smooth plan against the ticks",
    )
    plan.add_argument(
        "--plot-from",
        type=non_negative_float,
        metavar="S",
        help="with --plot: start the plot at S seconds (default 0), for a close look at a "
        "long motion",
    )
    plan.add_argument(
        "--plot-to",
        type=non_negative_float,
        metavar="S",
        help="with --plot: end the plot at S seconds (default: the end of the motion)",
    )
    add_planning_arguments(plan)
    plan.set_defaults(handler=run_plan)


def png_path(text: str) -> Path:
    if not text.lower().endswith(".png"):
        raise argparse.ArgumentTypeError(
            f"the plot is a PNG: the file must end in .png, got {text!r}"
        )
    return Path(text)


def run_plan(args: argparse.Namespace) -> int:
    window_asked = args.plot_from is not None or args.plot_to is not None
    if window_asked and args.plot is None:
        raise UsageError("--plot-from and --plot-to choose what --plot draws: add --plot FILE.png")
    if args.plot_from is not None and args.plot_to is not None and args.plot_from >= args.plot_to:
        raise UsageError(
            f"--plot-from {args.plot_from:g} must be before --plot-to {args.plot_to:g}"
        )
    if args.plot is not None:
        from choreo.core.atomic import check_writable  # only with a plot to write

        check_writable(args.plot)
    motion = load_dance(args.motion, args.allow_past_song)
    compiled = compile_motion(motion, plan_options(args))
    window = plot_window(args, compiled.trajectory.duration_s) if window_asked else None
    speed = motion.speed if args.speed is None else args.speed
    report = plan_report(motion, compiled, speed, keyframes=args.json)  # the table has none
    if args.json:
        print(json.dumps(report, indent=2, ensure_ascii=False))
    else:
        print_report(report)
    if args.plot is not None:
        from choreo.plan.plot import plot_plan  # matplotlib: only when a plot is asked for

        plot_plan(
            compiled.trajectory,
            compiled.ticks,
            motion.robot,
            args.plot,
            title=f"{motion.name} ({args.motion}): {report['duration_s']:.2f} s, "
            f"{report['ticks']} ticks, {report['bytes']} bytes, max deviation "
            f"{report['max_deviation_deg']:.2f}°"
            + (f"; {window[0]:g}..{window[1]:g} s shown" if window else ""),
            window_s=window,
        )
        if not args.json:
            print(f"wrote {args.plot}")
    return 0


def plot_window(args: argparse.Namespace, duration_s: float) -> tuple[float, float]:
    """--plot-from/--plot-to as a time window of the planned motion; refused outside it, not
    clamped."""
    start_s = 0.0 if args.plot_from is None else args.plot_from
    end_s = duration_s if args.plot_to is None else args.plot_to
    for option, value in (("--plot-from", start_s), ("--plot-to", end_s)):
        if value > duration_s + 1e-9:
            raise UsageError(
                f"{option} {value:g} is past the end of the motion: it lasts {duration_s:.3f} s"
            )
    if start_s >= end_s:
        raise UsageError(f"--plot-from {start_s:g} must be before the end, {end_s:.3f} s")
    return start_s, end_s


def print_report(report: dict) -> None:
    from rich.console import Console  # rich (some 0.07 s to import): not for --json
    from rich.table import Table

    console = Console(highlight=False, soft_wrap=True)  # long paths stay on one line
    speed = f" at speed {report['speed']:g}" if report["speed"] != 1 else ""
    console.print(
        f"[bold]{report['motion']}[/] on {report['robot']}{speed}: "
        f"{report['duration_s']:.3f} s, {report['keyframes']} keyframes played"
    )
    console.print(
        f"{report['ticks']} ticks, {report['bytes']} bytes, peak bus use "
        f"{100 * report['peak_bus_use']:.0f} %, max deviation "
        f"{report['max_deviation_deg']:.3f}° (tolerance {report['tolerance_deg']:g}° "
        f"+ 0.12° rounding)"
    )
    for stretch in report["stretches"]:
        console.print(
            f"[yellow]{stretch['where']}: stretched: reached {stretch['shift_s']:.3f} s "
            f"later than asked[/]"
        )
    table = Table(show_edge=False, pad_edge=False)
    for header in ("joint", "peak °/s", "limit", "use", "peak °/s²", "limit", "use", "moves"):
        table.add_column(header, justify="left" if header == "joint" else "right")
    for j in report["joints"]:
        vel_use = j["peak_velocity_deg_s"] / j["velocity_limit_deg_s"]
        acc_use = j["peak_acceleration_deg_s2"] / j["acceleration_limit_deg_s2"]
        table.add_row(
            j["name"],
            f"{j['peak_velocity_deg_s']:.0f}",
            f"{j['velocity_limit_deg_s']:.0f}",
            _percent(vel_use),
            f"{j['peak_acceleration_deg_s2']:.0f}",
            f"{j['acceleration_limit_deg_s2']:.0f}",
            _percent(acc_use),
            str(j["staged_moves"]),
        )
    console.print(table)


def _percent(share: float) -> str:
    style = "bold" if share > 0.95 else ""
    text = f"{100 * share:.0f} %"
    return f"[{style}]{text}[/]" if style else text
