"""``choreo validate``: every check that can be made before anything moves."""

from __future__ import annotations

import argparse

from choreo.cli import in_flags
from choreo.cli.arguments import add_past_song_argument, file_path
from choreo.validate import check_file


def register(subparsers) -> None:
    validate = subparsers.add_parser(
        "validate",
        help="check motion, robot and show files, reporting every problem",
        description="Check motion files, robot files (named robot.yaml) and show files (with a "
        "performers: list; every performer's motion too) without moving "
        "anything: a motion is loaded, planned, compiled into servo ticks and "
        "simulated. Prints 'FILE: ok' per good file, else every problem as "
        "'path:line:col: message'; exits 1 if any file has a problem.",
    )
    validate.add_argument(
        "--no-physics",
        action="store_true",
        help="skip the physics preview (faster; no collision or stall checks)",
    )
    validate.add_argument(
        "--stretch",
        action="store_true",
        help="move keyframes later where the limits can't meet their times, as "
        "`choreo play --stretch` does, and warn instead of failing",
    )
    add_past_song_argument(validate)
    validate.add_argument(
        "files",
        nargs="+",
        type=file_path,
        metavar="FILE",
        help="a motion .yaml, a robot.yaml or a show .yaml",
    )
    validate.set_defaults(handler=run_validate)


def run_validate(args: argparse.Namespace) -> int:
    failed = False
    for path in args.files:
        result = check_file(
            path,
            physics=not args.no_physics,
            stretch=args.stretch,
            allow_past_song=args.allow_past_song,
        )
        for line in result.problems:
            print(in_flags(line))
        for line in result.warnings:
            print(f"warning: {in_flags(line)}")
        if result.ok:
            print(f"{path}: ok")
        failed = failed or not result.ok
    return 1 if failed else 0
