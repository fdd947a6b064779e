"""``choreo identify``: measure the robot's servos where it stands (``choreo.identify``)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from choreo.cli.arguments import add_port_arguments, bus_settings, file_path, stop_signals_as_ctrl_c

if TYPE_CHECKING:  # the modules themselves are imported when the command runs
    from choreo.bus.settings import BusSettings
    from choreo.identify.identify import IdentifyReport
    from choreo.robot.types import Robot

FIGURE_WORDS = (
    ("deadband_deg", "dead band {:.2f}°"),
    ("backlash_deg", "backlash {:.2f}°"),
    ("no_load_speed_deg_s", "speed {:.0f}°/s"),
    ("kp_nm_rad", "gain {:.1f} N·m/rad"),
    ("stall_torque_nm", "stall {:.2f} N·m"),
    ("friction_nm", "friction {:.3f} N·m"),
    ("response_delay_s", "delay {:.1f} ms"),
    ("offset_deg", "offset {:+.2f}°"),
)


def register(subparsers) -> None:
    identify = subparsers.add_parser(
        "identify",
        help="measure each servo on the robot and fit the preview's model of it",
        description="One joint at a time, the others holding the pose the robot stands in: "
        "gentle test moves inside the joint's limits (slow triangles, small reversals, steps "
        "at several move times, holds in several poses), read as fast as the bus allows; the "
        "preview's servo model is fitted to them and checked on held-out moves. The figures go "
        "to a servo figures file (written after every joint: run again to go on) that the "
        "robot file names (servo_figures: FILE) for the preview, the planner and the gaits. "
        "Ctrl-C stops with every servo holding.",
    )
    identify.add_argument(
        "target",
        metavar="MOTION|ROBOT",
        help="a robot (name or robot.yaml): all its joints; or a motion: the joints it moves",
    )
    identify.add_argument("--joints", nargs="+", metavar="JOINT", help="only these joints")
    identify.add_argument(
        "-o",
        "--output",
        type=file_path,
        metavar="FILE",
        help="the servo figures file (default: the one the robot file names, else "
        "servo_figures.yaml beside robot.yaml)",
    )
    identify.add_argument(
        "--drop",
        nargs="+",
        metavar="JOINT",
        default=(),
        help="joints that may fall freely for a moment: their torque is switched off once "
        "(measures the horn's offset); only where a fall harms nothing",
    )
    identify.add_argument(
        "--again", action="store_true", help="measure joints the file already has again"
    )
    add_port_arguments(identify)
    identify.set_defaults(handler=run_identify)


def run_identify(args: argparse.Namespace) -> int:
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from choreo.bus.servo_bus import ServoBus
    from choreo.identify import JointResult, identify
    from choreo.identify import Progress as Step

    robot, joints = _robot_and_joints(args.target, args.joints)
    output = args.output or _default_output(robot)
    settings = _emulated_unless_a_port(bus_settings(args, robot), robot)
    bar = Progress(
        TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(), transient=True
    )
    task = bar.add_task("starting", total=1.0)

    def on_progress(step: Step) -> None:
        done = (step.index + _STAGES.get(step.stage, 0.0) + 0.3 * step.fraction) / step.count
        bar.update(
            task,
            completed=min(done, 1.0),
            description=f"{step.joint} ({step.index + 1}/{step.count}): {step.stage}",
        )

    def on_joint(result: JointResult) -> None:
        bar.console.print(_joint_line(result))

    with stop_signals_as_ctrl_c(), ServoBus.from_settings(settings) as bus, bar:
        report = identify(
            robot,
            bus,
            output,
            joints=joints,
            drop=tuple(args.drop),
            again=args.again,
            on_progress=on_progress,
            on_joint=on_joint,
        )
    _print_summary(report, output, robot)
    return 0


def _emulated_unless_a_port(settings: BusSettings, robot: Robot) -> BusSettings:
    """Without --port: the emulated robot whose servos are the physics."""
    if settings.port is not None:
        return settings
    stand = "&stand=1" if robot.free_floating else ""  # a walker is measured on a stand
    settings = dataclasses.replace(settings, port=f"sim://?physics={robot.path}{stand}")
    print(
        f"no --port given: identifying the emulated {robot.name} whose servos are the "
        f"physics ({settings.port})",
        file=sys.stderr,
    )
    return settings


def _print_summary(report: IdentifyReport, output: Path, robot: Robot) -> None:
    if report.already:
        print(f"kept from {output}: {', '.join(report.already)} (--again measures them again)")
    if report.identified:
        rates = [r.reads_per_s for r in report.identified]
        print(
            f"wrote {output}: {len(report.identified)} joint(s), "
            f"{sum(rates) / len(rates):.0f} position reads/s"
        )
    if report.gait is not None:
        gait = report.gait
        print(
            f"gait compensation recalibrated in the preview with these figures (in {output}): "
            f"lift +{gait.lift_sag_mm:g} mm, stride x{gait.stride_scale:g}, "
            f"turn x{gait.turn_scale:g}"
        )
    if report.gait_problem is not None:
        print(f"gait compensation not recalibrated: {report.gait_problem}")
    if robot.servo_figures is None or Path(robot.servo_figures.path).resolve() != output.resolve():
        print(f"to use it, add to {robot.path}:  servo_figures: {_relative(output, robot.path)}")


_STAGES = {"test moves": 0.0, "held-out moves": 0.3, "fitting": 0.6}


def _joint_line(result) -> str:
    figures = ", ".join(
        words.format(result.figures[key] * (1000 if key == "response_delay_s" else 1))
        for key, words in FIGURE_WORDS
        if key in result.figures
    )
    v = result.validation
    better = f"{100 * v.improvement:.0f} % less" if math.isfinite(v.improvement) else "n/a"
    rate = f"{result.reads_per_s:.0f} reads/s"
    if result.neighbours_moved_deg:  # its neighbours were read along
        rate += f" ({result.own_reads_per_s:.0f} its own)"
    line = (
        f"{result.joint}: {figures}; held-out error median {v.fitted_median_deg:.2f}° "
        f"(p95 {v.fitted_p95_deg:.2f}°) against {v.default_median_deg:.2f}° "
        f"(p95 {v.default_p95_deg:.2f}°) assumed: {better}; {rate}"
    )
    if result.neighbours_gave_way:
        moved = ", ".join(f"{name} {deg:.1f}°" for name, deg in result.neighbours_gave_way.items())
        line += (
            f"\n  {result.joint}'s neighbours gave way under its moves (up to {moved}): "
            "the fit replayed their measured motion"
        )
    return line


def _robot_and_joints(target: str, joints):
    """The robot, and the joints to identify: those named, else a motion's moving ones, else
    all."""
    from choreo.motion.motion_file import load_motion
    from choreo.robot.lookup import ROBOT_FILE, is_robot_path
    from choreo.robot.robot_file import load_robot

    path = Path(target)
    if is_robot_path(target) and (path.is_dir() or path.name == ROBOT_FILE):
        return load_robot(target, with_figures=False), joints
    if not is_robot_path(target):
        return load_robot(target, with_figures=False), joints
    motion = load_motion(target)
    robot = load_robot(motion.robot.path, with_figures=False)
    if joints is None:
        import numpy as np

        targets = np.array([keyframe.targets_deg for keyframe in motion.keyframes])
        moving = np.ptp(targets, axis=0) > 0 if len(targets) > 1 else np.zeros(0, dtype=bool)
        joints = [name for name, moves in zip(robot.joint_names, moving) if moves] or None
    return robot, joints


def _default_output(robot) -> Path:
    if robot.servo_figures is not None:
        return Path(robot.servo_figures.path)
    return robot.path.parent / "servo_figures.yaml"


def _relative(output: Path, robot_path: Path) -> str:
    try:
        return str(output.resolve().relative_to(robot_path.resolve().parent))
    except ValueError:
        return str(output.resolve())
