"""``choreo import d6a``, ``choreo export d6a`` and ``choreo mirror``: bringing motions in and
out of choreo, and turning them left for right."""

from __future__ import annotations

import argparse

from choreo.cli.arguments import add_output_arguments, file_path, id_sequence
from choreo.core.atomic import check_writable
from choreo.interop.d6a import TIME_RANGE_MS, export_d6a, import_d6a
from choreo.motion.mirror import write_mirrored
from choreo.motion.motion_file import load_motion
from choreo.robot.robot_file import load_robot


def register(subparsers) -> None:
    importer = subparsers.add_parser(
        "import", help="turn another program's motion file into a choreo motion"
    )
    formats = importer.add_subparsers(dest="format", metavar="FORMAT", required=True)
    d6a_in = formats.add_parser(
        "d6a",
        help="a Hiwonder action group (.d6a, from the vendor's PC editor)",
        description="Each row becomes a keyframe reached `after` the row's Time (in seconds), so "
        "every time is kept to the millisecond; row 1 is reached by choreo's "
        "approach. Servo positions outside a joint's limits are all reported, never "
        "clamped.",
    )
    d6a_in.add_argument("file", type=file_path, metavar="FILE.d6a", help="the action group")
    d6a_in.add_argument(
        "--robot",
        required=True,
        help="the robot: a name (models/<name>) or a path to its robot.yaml",
    )
    add_output_arguments(d6a_in, "OUT.yaml", "the motion file to write")
    d6a_in.add_argument(
        "--ids",
        type=id_sequence,
        metavar="IDS",
        help="the servo ID of each Servo column in order, e.g. 1-18,21-25 "
        "(default: ServoK is servo ID K)",
    )
    d6a_in.set_defaults(handler=run_import_d6a)

    exporter = subparsers.add_parser(
        "export", help="write a choreo motion in another program's format"
    )
    formats = exporter.add_subparsers(dest="format", metavar="FORMAT", required=True)
    d6a_out = formats.add_parser(
        "d6a",
        help="a Hiwonder action group (.d6a) for the vendor's runner",
        description="One row per keyframe (and one per hold) with column ServoK for servo ID K; "
        "a row's Time is the time between leaving the keyframe before and reaching "
        f"this one, {TIME_RANGE_MS[0]}..{TIME_RANGE_MS[1]} ms. The vendor's runner "
        "moves in straight lines between rows: stop, velocity and choreo's "
        "smoothing are not kept.",
    )
    d6a_out.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    add_output_arguments(d6a_out, "OUT.d6a", "the action group file to write")
    d6a_out.set_defaults(handler=run_export_d6a)

    mirror = subparsers.add_parser(
        "mirror",
        help="write a motion mirrored left <-> right",
        description="Swap left and right with the robot's mirror pairs; every keyframe keeps its "
        "timing, hold, stop and velocity (includes are written out in place), and the motion "
        "its name, start, end and props (reflected in the x-z plane, as the robot is).",
    )
    mirror.add_argument("motion", type=file_path, metavar="MOTION", help="a motion .yaml file")
    add_output_arguments(mirror, "OUT.yaml", "the motion file to write")
    mirror.set_defaults(handler=run_mirror)


def run_import_d6a(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite)
    robot = load_robot(args.robot)
    keyframes = import_d6a(args.file, robot, args.output, args.ids)
    print(
        f"wrote {args.output}: {_count(len(keyframes), 'keyframe')} for {robot.name} from "
        f"{args.file}"
    )
    return 0


def run_export_d6a(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite)
    motion = load_motion(args.motion)
    rows = export_d6a(motion, args.output)
    total_s = sum(row.time_ms or 0 for row in rows) / 1000  # exported rows are all timed
    print(f"wrote {args.output}: {_count(len(rows), 'row')}, {total_s:g} s, from {args.motion}")
    return 0


def run_mirror(args: argparse.Namespace) -> int:
    check_writable(args.output, overwrite=args.overwrite)
    motion = load_motion(args.motion)
    keyframes = write_mirrored(motion, args.output)
    print(f"wrote {args.output}: {_count(len(keyframes), 'keyframe')}, {motion.name} mirrored")
    return 0


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}{'' if n == 1 else 's'}"
