"""``choreo record``: teach a motion by hand (the logic is in ``choreo.play.recorder``)."""

from __future__ import annotations

import argparse
import queue
import sys
import threading

from choreo.cli.arguments import (
    add_port_arguments,
    bus_settings,
    file_path,
    positive_float,
    say_built_in_emulator,
    stop_signals_as_ctrl_c,
)
from choreo.core.clock import RealClock
from choreo.errors import BusError, ChoreoError, UsageError
from choreo.play.recorder import (
    Captured,
    Ending,
    Event,
    NothingToUndo,
    Recorder,
    Refused,
    Undone,
    UnknownInput,
)
from choreo.play.recording import Recording, journal_path
from choreo.play.robot_bus import robot_bus
from choreo.robot.robot_file import load_robot
from choreo.robot.types import Robot

KEYS = "Enter = capture every joint, u = undo the last capture, q = save and quit"


def register(subparsers) -> None:
    record = subparsers.add_parser(
        "record",
        help="teach a motion by hand: pose the robot, capture keyframes",
        description="Unload the joints to teach (the others hold), pose them by hand and capture "
        "keyframes; or sample a stream with --continuous. Every capture goes to "
        "OUT.yaml.journal at once, so nothing is lost if the program or the cable "
        "dies: --resume continues. The taught joints are loaded again at the end.",
    )
    record.add_argument("out", type=file_path, metavar="OUT.yaml", help="the motion file to write")
    record.add_argument(
        "--robot",
        help="robot name or path to its robot.yaml (with --resume, default: the journal's robot)",
    )
    add_port_arguments(record)
    record.add_argument(
        "--joints",
        nargs="+",
        metavar="JOINT",
        help="the joints to teach, unloaded (default: all); the others hold",
    )
    record.add_argument(
        "--continuous",
        type=positive_float,
        metavar="HZ",
        help="sample every joint at HZ until Enter or q, then reduce the stream to keyframes",
    )
    record.add_argument(
        "--tolerance",
        type=positive_float,
        default=1.0,
        metavar="DEG",
        help="how far the reduced keyframes may stray from the stream (default 1°)",
    )
    record.add_argument(
        "--resume",
        action="store_true",
        help="continue an unfinished recording from OUT.yaml.journal",
    )
    record.add_argument("--overwrite", action="store_true", help="replace an existing OUT.yaml")
    record.add_argument(
        "--leave-unloaded",
        action="store_true",
        help="leave the taught joints limp at the end (default: load them)",
    )
    record.set_defaults(handler=run_record)


def run_record(args: argparse.Namespace) -> int:
    if args.robot is None and not args.resume:
        raise UsageError("--robot is required (unless --resume takes the journal's)")
    if args.resume:
        recording = Recording.resume(args.out, load_robot(args.robot) if args.robot else None)
        print(
            f"resuming {args.out}: {len(recording.captures)} capture(s) from "
            f"{recording.journal.path}"
        )
    else:
        recording = Recording.start(args.out, load_robot(args.robot), overwrite=args.overwrite)
    try:
        with stop_signals_as_ctrl_c():
            return _record(args, recording)
    except (BusError, KeyboardInterrupt) as error:
        journal = journal_path(args.out)
        if not journal.exists() or not recording.captures:
            raise  # nothing kept to resume from (or the motion was saved already)
        reason = "interrupted" if isinstance(error, KeyboardInterrupt) else str(error)
        raise ChoreoError(
            f"{reason}; the {len(recording.captures)} capture(s) so far are kept in "
            f"{journal}: run again with --resume"
        ) from error
    finally:
        recording.close()


def _record(args: argparse.Namespace, recording: Recording) -> int:
    robot = recording.robot
    settings = bus_settings(args, robot)
    if settings.port is None:
        say_built_in_emulator(robot, "recording on")
        print(
            "(nobody can turn emulated servos by hand, so every capture is the home pose)",
            file=sys.stderr,
        )
    printer = _EventPrinter(robot)
    with robot_bus(robot, None, settings) as bus:
        with Recorder(
            bus,
            recording,
            RealClock(),
            taught=_joint_names(args.joints),
            leave_unloaded=args.leave_unloaded,
            on_event=printer,
        ) as recorder:
            held = ", ".join(j.name for j in recorder.held) or "none"
            print(
                f"unloaded, pose by hand: {', '.join(j.name for j in recorder.taught)}; "
                f"holding: {held}"
            )
            if args.continuous:
                print(f"sampling at {args.continuous:g} Hz: press Enter (or q) to stop")
                ending = recorder.run_stream(_StdinLines(), args.continuous)
                print(f"stream: {printer.samples} sample(s)")
            else:
                print(KEYS)
                ending = recorder.run_keyframes(_prompt)
            saved = recording.save(args.tolerance)
            if saved is None:
                print(f"nothing captured: {args.out} not written")
            else:
                print(
                    f"saved {saved.path}: {saved.keyframes} keyframe(s) from {saved.captures} "
                    "capture(s)"
                )
    print(
        "taught joints left unloaded"
        if args.leave_unloaded
        else "taught joints loaded again, holding where they are"
    )
    if saved is None:
        return 1
    return 130 if ending is Ending.INTERRUPTED else 0


def _joint_names(values: list[str] | None) -> list[str] | None:
    """``--joints a b`` or ``--joints a,b``."""
    if values is None:
        return None
    return [name for value in values for name in value.split(",") if name]


def _prompt() -> str:
    return input("> " if sys.stdin.isatty() else "")


class _StdinLines:
    """Lines typed on stdin, read by a thread, so the sampler can ask without waiting."""

    _END = object()

    def __init__(self) -> None:
        self._lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in sys.stdin:
            self._lines.put(line.rstrip("\r\n"))
        self._lines.put(self._END)

    def __call__(self) -> str | None:
        try:
            line = self._lines.get_nowait()
        except queue.Empty:
            return None
        if line is self._END:
            raise EOFError
        return line


class _EventPrinter:
    def __init__(self, robot: Robot):
        self.robot = robot
        self.samples = 0

    def __call__(self, event: Event) -> None:
        text = self._describe(event)
        if text is not None:
            print(text, flush=True)

    def _describe(self, event: Event) -> str | None:
        if isinstance(event, Captured):
            if event.capture.stream is not None:
                self.samples += 1
                return None
            return self._captured(event)
        if isinstance(event, Refused):
            return "not captured: " + "; ".join(event.problems)
        if isinstance(event, Undone):
            return f"undid #{event.number}; {event.remaining} capture(s) left"
        if isinstance(event, NothingToUndo):
            return "nothing to undo"
        if isinstance(event, UnknownInput):
            return f"unknown command {event.text!r}: {KEYS}"
        raise TypeError(f"unknown event {event!r}")

    def _captured(self, event: Captured) -> str:
        timing = (
            "start" if event.capture.after_s is None else f"after {event.capture.after_s:.2f} s"
        )
        angles = "  ".join(
            f"{name} {angle:.1f}"
            for name, angle in zip(self.robot.joint_names, event.capture.angles_deg)
        )
        return f"#{event.number} ({timing}): {angles}"
