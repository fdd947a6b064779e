"""``choreo plan``: plan a motion and compile its ticks; report the figures, optionally plot."""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from rich.table import Table

from ..atomic import check_writable
from ..errors import UsageError
from ..motion import Motion, load_motion
from ..music import Music
from ..pipeline import CompiledMotion, compile_motion
from .arguments import add_planning_arguments, non_negative_float


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
    plan.add_argument("motion", type=Path, metavar="MOTION", help="a motion .yaml file")
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


@dataclass(frozen=True)
class JointFigures:
    name: str
    peak_velocity_deg_s: float
    velocity_limit_deg_s: float
    peak_acceleration_deg_s2: float
    acceleration_limit_deg_s2: float
    staged_moves: int


def run_plan(args: argparse.Namespace) -> int:
    window_asked = args.plot_from is not None or args.plot_to is not None
    if window_asked and args.plot is None:
        raise UsageError("--plot-from and --plot-to choose what --plot draws: add --plot FILE.png")
    if args.plot_from is not None and args.plot_to is not None and args.plot_from >= args.plot_to:
        raise UsageError(
            f"--plot-from {args.plot_from:g} must be before --plot-to {args.plot_to:g}"
        )
    if args.plot is not None:
        check_writable(args.plot)
    motion = load_motion(args.motion)
    compiled = compile_motion(
        motion, speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance
    )
    window = plot_window(args, compiled.trajectory.duration_s) if window_asked else None
    speed = motion.speed if args.speed is None else args.speed
    report = plan_report(args.motion, motion, speed, compiled)
    if args.json:
        print(json.dumps(report, indent=2, ensure_ascii=False))
    else:
        print_report(report)
    if args.plot is not None:
        from ..plot import plot_plan  # matplotlib: only when a plot is asked for

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


def plan_report(path: Path, motion: Motion, speed: float, compiled: CompiledMotion) -> dict:
    """The figures ``choreo plan`` prints, as plain JSON-ready values."""
    trajectory, ticks = compiled.trajectory, compiled.ticks
    peak_vel = trajectory.peak_velocity_deg_s()
    peak_acc = trajectory.peak_acceleration_deg_s2()
    joints = [
        JointFigures(
            joint.name,
            float(peak_vel[j]),
            joint.limits.vel_deg_s,
            float(peak_acc[j]),
            joint.limits.acc_deg_s2,
            sum(t.staged[j] for t in ticks.ticks),
        )
        for j, joint in enumerate(motion.robot.joints)
    ]
    return {
        "motion": str(path),
        "robot": motion.robot.name,
        "speed": speed,
        "duration_s": trajectory.duration_s,
        "keyframes": len(trajectory.keyframe_times_s),
        "keyframe_times_s": [float(t) for t in trajectory.keyframe_times_s],
        "music": music_report(motion.music) if motion.music else None,
        "ticks": len(ticks.ticks),
        "bytes": ticks.total_bytes,
        "peak_bus_use": ticks.peak_bus_use,
        "tolerance_deg": ticks.tolerance_deg,
        "max_deviation_deg": ticks.max_deviation_deg,
        "stretches": [{"where": str(s.where), "shift_s": s.shift_s} for s in compiled.stretches],
        "joints": [vars(j) for j in joints],
        "expanded_keyframes": expanded_keyframes(motion),
    }


def expanded_keyframes(motion: Motion) -> list[dict]:
    """Every keyframe as the planner gets it (includes, gaits and IK expanded): joint angles."""
    names = motion.robot.joint_names
    return [
        {
            "where": str(k.where),
            **({"label": k.label} if k.label else {}),
            **({"t_s": k.t_s} if k.t_s is not None else {}),
            **({"after_s": k.after_s} if k.after_s is not None else {}),
            **({"hold_s": k.hold_s} if k.hold_s else {}),
            "stop": k.stop,
            "targets_deg": {name: round(a, 3) for name, a in zip(names, k.targets_deg)},
        }
        for k in motion.keyframes
    ]


def music_report(music: Music) -> dict:
    return {
        "song": str(music.song),
        "start_s": music.start_s,
        "bpm": music.bpm,
        "beats_per_bar": music.grid.beats_per_bar,
        "beat_times_s": list(music.grid.beat_times_s),  # motion time of beat 1, 2, ...
    }


def print_report(report: dict) -> None:
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
