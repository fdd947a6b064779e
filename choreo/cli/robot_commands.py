"""``choreo robots``: the robots a motion can name, with their joints, limits and poses."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

from choreo.errors import SourceError
from choreo.robot.lookup import known_robots, robot_search_dirs
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot


def register(subparsers) -> None:
    robots = subparsers.add_parser(
        "robots",
        help="list the robots, or show one's joints, limits and poses",
        description="Without NAME: every robot found (models/<name>/robot.yaml from here up, "
        "$CHOREO_MODELS, the shipped models) with its joints and poses. With NAME (or a path "
        "to a robot.yaml): its joints with servo ID, limits and rates, and its poses: what a "
        "motion file can use.",
    )
    robots.add_argument("name", nargs="?", metavar="NAME", help="a robot name or robot.yaml path")
    robots.set_defaults(handler=run_robots)


def run_robots(args: argparse.Namespace) -> int:
    # piped or redirected: the table at its natural width, never squeezed to 80 columns
    console = Console(highlight=False, soft_wrap=True, width=None if sys.stdout.isatty() else 1000)
    if args.name is not None:
        show_robot(console, load_robot(args.name))
        return 0
    search_dirs = robot_search_dirs(Path())
    names = known_robots(search_dirs)
    if not names:
        folders = ", ".join(map(str, search_dirs)) or "no models folder"
        print(f"no robots found (looked for <name>/robot.yaml in {folders})")
        return 1
    failed = False
    for name in names:
        try:
            robot = load_robot(name)
        except SourceError as error:
            failed = True
            console.print(f"[bold]{name}[/]: [red]cannot be loaded:[/] {error.problems[0]}")
            continue
        console.print(
            f"[bold]{name}[/]: {len(robot.joints)} joints, poses {', '.join(robot.poses)} "
            f"({_shown(robot.path)})"
        )
    print("`choreo robots NAME` shows a robot's joints, limits and poses")
    return 1 if failed else 0


def show_robot(console: Console, robot: Robot) -> None:
    """One row per joint: servo, limits, rates, and its angle in each pose."""
    console.print(f"[bold]{robot.name}[/] ({_shown(robot.path)})")
    table = Table(show_edge=False, pad_edge=False)
    columns = ["joint", "id", "servo", "min °", "max °", "°/s", "°/s²", "°/s³"]
    for column in columns:
        table.add_column(column, justify="left" if column in ("joint", "servo") else "right")
    for pose in robot.poses:
        table.add_column(f"{pose} °", justify="right")
    poses = [robot.pose_vector(pose) for pose in robot.poses]
    for j, joint in enumerate(robot.joints):
        limits = joint.limits
        table.add_row(
            joint.name,
            str(joint.servo_id),
            joint.servo_model,
            f"{limits.min_deg:g}",
            f"{limits.max_deg:g}",
            f"{limits.vel_deg_s:g}",
            f"{limits.acc_deg_s2:g}",
            f"{limits.jerk_deg_s3:g}",
            *(f"{pose[j]:g}" for pose in poses),
        )
    console.print(table)
    if robot.mirror_pairs:
        pairs = ", ".join(
            f"{p.left} <-> {p.right}" + (" (sign -1)" if p.sign < 0 else "")
            for p in robot.mirror_pairs
        )
        console.print(f"mirror: {pairs}")


def _shown(path: Path) -> str:
    """A path relative to the working directory where it is below it."""
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)
