"""Playing a motion, in one call: what ``choreo play`` does, for programs.

    report = play_motion("motions/arm6/wave.yaml", port="sim://?ids=1-6")

Load (when given a path), compile, preflight every servo, approach the first pose slowly, play
with health reads and the song, leave the servos as ``options.exit_mode`` says, and return the
report. Without a port the robot file's ``bus: port`` is used, and without one either the
built-in emulator: the robot's servos standing at its home pose. The bus keeps time on the clock
its backend declares (an emulator's virtual clock included), and on an emulator the report gives
how far the servos' paths strayed from the plan, measured on its wire.
"""

from __future__ import annotations

import bisect
import dataclasses
import logging
import os
from collections.abc import Callable

from choreo.bus.servo_bus import PORT_EXAMPLES, ServoBus
from choreo.bus.settings import BusSettings
from choreo.core.arguments import check_callable, check_type, shown
from choreo.emulator.trace import WireTrace, start_skew_ms
from choreo.errors import NoAudioOutput, OptionError
from choreo.motion.dance import dance_of
from choreo.motion.motion_file import Motion
from choreo.motion.music_block import check_speed
from choreo.music.decode import Audio
from choreo.plan.performance import Performance, prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.path_errors import measured_path_errors
from choreo.play.play_options import PlayOptions
from choreo.play.player import Player
from choreo.play.preflight import preflight, unchecked
from choreo.play.realtime import Scheduling
from choreo.play.report import PlayProgress, PlayReport, StreamReport
from choreo.play.robot_bus import robot_bus
from choreo.play.soundtrack import (
    AudioSink,
    SongCue,
    SoundDeviceSink,
    play_with_song,
    song_for_output,
)

log = logging.getLogger(__name__)

Note = Callable[[str], None]
OpenAudio = Callable[[str | None, float | None], AudioSink]
DEFAULT_OPTIONS = PlayOptions()
PLAY_OPTIONS = "a PlayOptions, e.g. PlayOptions(speed=2) (from a dict: PlayOptions(**options))"


def play_motion(
    motion: Motion | str | os.PathLike[str],
    port: str | os.PathLike[str] | ServoBus | None = None,
    options: PlayOptions = DEFAULT_OPTIONS,
    *,
    bus_settings: BusSettings | None = None,
    open_audio: OpenAudio = SoundDeviceSink,
    on_progress: Callable[[PlayProgress], None] | None = None,
    on_note: Note = log.warning,
) -> PlayReport:
    """Play ``motion`` on the servos behind ``port`` and return the report.

    ``port``: a port string, or a :class:`ServoBus` you opened (left open); ``None``: the
    ``bus_settings``' port, else the robot file's, else the built-in emulator. ``bus_settings``
    (timeout, retries, echo, direction) default to the robot file's ``bus:`` section.
    ``open_audio(device, latency_s)``: opens the output the song of a motion with a ``music:``
    block plays on, when ``options.audio`` (default: the system's, through sounddevice).
    ``on_note`` hears what a user should know before and while it plays (a keyframe
    stretched, a check the transport cannot make, no audio output). Ctrl-C
    (KeyboardInterrupt) stops the servos at once and ends with outcome ``interrupted``; a
    failed health check, ``aborted``.
    """
    check_type("options", options, PlayOptions, PLAY_OPTIONS)
    if bus_settings is not None:
        check_type("bus_settings", bus_settings, BusSettings, "a BusSettings, or None")
    check_callable("open_audio", open_audio)
    check_callable("on_progress", on_progress, optional=True)
    check_callable("on_note", on_note)
    port = _port_or_bus(port)
    motion = prepared_motion(motion, options, on_note)
    robot = motion.robot
    compiled = compile_motion(motion, options.plan)
    for stretch in compiled.stretches:  # said before anything moves
        on_note(stretch.describe())
    with robot_bus(robot, port, bus_settings) as bus:
        missing = unchecked(bus)
        if missing:
            on_note(
                f"note: the {bus.capabilities.transport} cannot read the servos' "
                f"{', '.join(missing)}: not checked"
            )
        start_pose, limits = preflight(bus, robot)
        performance = prepare(compiled, start_pose)
        sink, song = _audio_output(motion, options, open_audio, on_note)
        cue = SongCue.of(motion.music, performance) if motion.music and sink else None
        if sink is not None:  # the stream needs the output's latency before the first START
            lead_s = max(options.lead_s, sink.latency_s + 0.05)
            options = dataclasses.replace(options, lead_s=lead_s)
        staged = _with_stage(on_progress, performance) if on_progress else None
        player = Player(bus, robot, bus.clock, limits, options, on_progress=staged)
        player.on_scheduling = _once(lambda scheduling: on_note(scheduling.describe()))
        report = play_with_song(player, performance, start_pose, sink, song, cue)
        exit_move = player.leave(report.outcome)
        return _described(report, motion, bus, performance, start_pose, exit_move)


def _port_or_bus(port: object) -> str | ServoBus | None:
    """``play_motion``'s port as given (a path as its string); ``OptionError`` if it is none."""
    if isinstance(port, os.PathLike):
        port = os.fspath(port)
    if port is None or isinstance(port, (str, ServoBus)):
        return port
    raise OptionError(
        "port",
        f"must be a port name such as {PORT_EXAMPLES} (a str or os.PathLike), a ServoBus you "
        f"opened, or None, got {shown(port)}",
    )


def prepared_motion(
    motion: Motion | str | os.PathLike[str], options: PlayOptions, on_note: Note = log.warning
) -> Motion:
    """The motion to play (loaded from a path, played ``options.loop`` times: ``dance_of``),
    the options checked against it."""
    motion = dance_of(motion, options.allow_past_song, loop=options.loop, on_note=on_note)
    check_options(motion, options)
    return motion


def check_options(motion: Motion, options: PlayOptions) -> None:
    """Refuse options the motion cannot be played with (OptionError), before anything opens."""
    if options.audio:
        check_speed(motion.music, options.speed)
    if options.exit_pose not in motion.robot.poses:
        raise OptionError(
            "exit_pose",
            f"{options.exit_pose!r} is not a pose of {motion.robot.name}; poses: "
            f"{', '.join(motion.robot.poses)}",
        )


def _once(note: Callable[[Scheduling], None]) -> Callable[[Scheduling], None]:
    """The priority is said once: the move to the exit pose asks for it again."""
    said: list[Scheduling] = []

    def say(scheduling: Scheduling) -> None:
        if not said:
            said.append(scheduling)
            note(scheduling)

    return say


def _with_stage(
    on_progress: Callable[[PlayProgress], None], performance: Performance
) -> Callable[[PlayProgress], None]:
    """``on_progress`` told the stage too: the approach, or the last keyframe passed."""
    keyframes = [performance.approach_s + t for t in performance.trajectory.keyframe_times_s]

    def update(progress: PlayProgress) -> None:
        passed = bisect.bisect_right(keyframes, progress.time_s)
        stage = (
            "approach"
            if progress.time_s < performance.approach_s
            else f"keyframe {passed}/{len(keyframes)}"
        )
        on_progress(dataclasses.replace(progress, stage=stage))

    return update


def _audio_output(
    motion: Motion, options: PlayOptions, open_audio: OpenAudio, on_note: Note
) -> tuple[AudioSink | None, Audio | None]:
    """Where the song plays, and the song decoded for it; without an output, a note, and the
    dance goes on without the song."""
    if motion.music is None or not options.audio:
        return None, None
    try:
        song = song_for_output(motion.music)
        sink = open_audio(options.audio_device, options.audio_latency_s)
        return sink, song
    except NoAudioOutput as error:
        on_note(f"choreo: no audio output: {error}; playing without the music")
        return None, None


def _described(
    report: StreamReport,
    motion: Motion,
    bus: ServoBus,
    performance: Performance,
    start_pose: tuple[float, ...],
    exit_move: StreamReport | None,
) -> PlayReport:
    """The report with what the play was of and, on an emulator, what its wire log shows."""
    errors = skew_ms = None
    if bus.emulator is not None:
        moves = WireTrace.of(bus.emulator).moves
        errors = measured_path_errors(moves, motion.robot, performance, report, start_pose)
        skew_ms = start_skew_ms(moves, report.start_time_s, report.start_time_s + report.elapsed_s)
    return PlayReport.of(
        report,
        motion=str(motion.path),
        robot=motion.robot.name,
        port=bus.name,
        emulated=bus.emulator is not None,
        measured_start_skew_ms=skew_ms,
        path_errors_deg=tuple(errors) if errors is not None else None,
        exit_move=exit_move,
    )
