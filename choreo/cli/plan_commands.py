"""``choreo plan``: plan a motion and compile its ticks; report the figures, optionally plot."""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from rich.table import Table

from ..motion import Motion, load_motion
from ..music import Music
from ..segments import CompiledMotion, compile_motion
from .arguments import add_planning_arguments


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
    motion = load_motion(args.motion)
    compiled = compile_motion(
        motion, speed=args.speed, stretch=args.stretch, tolerance_deg=args.tolerance
    )
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
            f"{report['max_deviation_deg']:.2f}°",
        )
        if not args.json:
            print(f"wrote {args.plot}")
    return 0


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
    }


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
