"""``choreo validate`` (and later plan, preview, play)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import SourceError
from ..motion import load_motion
from ..robot import ROBOT_FILE, load_robot


def register(subparsers) -> None:
    validate = subparsers.add_parser(
        "validate",
        help="check motion and robot files, reporting every problem",
        description="Check motion files and robot files (named robot.yaml) without moving "
                    "anything. Prints 'FILE: ok' per good file, else every problem as "
                    "'path:line:col: message'; exits 1 if any file has a problem.",
    )
    validate.add_argument("files", nargs="+", type=Path, metavar="FILE",
                          help="a motion .yaml or a robot.yaml")
    validate.set_defaults(handler=run_validate)


def check_file(path: Path) -> list[str]:
    """Every problem of one motion or robot file, as ``path:line:col: message`` lines."""
    try:
        if path.name == ROBOT_FILE:
            load_robot(path)
        else:
            load_motion(path)
    except SourceError as error:
        return list(error.problems)
    return []


def run_validate(args: argparse.Namespace) -> int:
    failed = False
    for path in args.files:
        problems = check_file(path)
        for line in problems or [f"{path}: ok"]:
            print(line)
        failed = failed or bool(problems)
    return 1 if failed else 0
