"""Every public call checks what a program passes it, as the command line checks its flags: a bad
argument is refused with an OptionError naming it (a ChoreoError), never a bare ValueError,
TypeError, AttributeError or OverflowError, and nothing is clamped. The walk covers each name of
``choreo.__all__`` (and the option records its calls take) with wrong types, NaN, infinities,
zero, negatives and huge values; fast: the emulator in virtual time, the small arm6 wave."""

from __future__ import annotations

import math
from functools import cached_property
from pathlib import Path

import pytest
from paths import REPO

import choreo
from choreo import (
    BeatAnalysis,
    ChoreoError,
    ExitMode,
    OptionError,
    PlayOptions,
    PortError,
    RealClock,
    ServoBus,
    VirtualClock,
    compile_motion,
    load_motion,
    plan_motion,
    play_motion,
)
from choreo.bus.settings import BusSettings

WAVE = REPO / "motions" / "arm6" / "wave.yaml"
PORT = "sim://?ids=1-6&clock=virtual"
NAN, INF = math.nan, math.inf

# What no number argument takes, whatever its range; then the values a range leaves out.
NOT_NUMBERS = ["1", None, True, [1]]
NOT_FINITE = [NAN, INF, -INF]
HUGE = [1e308, 10**400]
NOT_POSITIVE = [0, 0.0, -1, -1e308]
NEGATIVE = [-1, -1e-9, -1e308]
POSITIVE_BAD = NOT_NUMBERS + NOT_FINITE + NOT_POSITIVE + [10**400]  # > 0, as large as wanted
BOUNDED_BAD = POSITIVE_BAD + HUGE  # > 0 and at most a limit
NON_NEGATIVE_BAD = NOT_NUMBERS + NOT_FINITE + NEGATIVE + [10**400]  # >= 0, as large as wanted
NON_NEGATIVE_BOUNDED_BAD = NON_NEGATIVE_BAD + HUGE  # >= 0 and at most a limit
WHOLE_BAD = NOT_NUMBERS + NOT_FINITE + [0, -1, 1.5, 2.0, 1e308]  # whole >= 1
NOT_FLAGS = ["yes", 1, None, NAN]
NOT_TEXT = [5, 1.5, NAN, b"home"]
NOT_PATHS = [5, NAN, None, "", b"wave.yaml", [str(WAVE)]]
NOT_CALLABLE = [5, "print", NAN]
NOT_OPTIONS = [{}, {"speed": 2}, "fast", 5, None]


def optional(values: list) -> list:
    """The values refused where ``None`` (not given) is taken."""
    return [value for value in values if value is not None]


class World:
    """What the calls need besides the argument under test, made once and only when asked."""

    @cached_property
    def motion(self):
        return load_motion(WAVE)

    @cached_property
    def compiled(self):
        return compile_motion(self.motion)

    @cached_property
    def bus(self):
        return ServoBus(PORT)

    @cached_property
    def pose_and_limits(self):
        return choreo.preflight(self.bus, self.motion.robot)

    @cached_property
    def player(self):
        return choreo.Player(**_player(self))

    @cached_property
    def performance(self):
        return choreo.prepare(self.compiled, self.pose_and_limits[0])

    @cached_property
    def report(self):
        return play_motion(self.motion, self.bus)

    @cached_property
    def rollout(self):
        return choreo.simulate_motion(self.motion)


@pytest.fixture(scope="module")
def world():
    made = World()
    yield made
    if "bus" in vars(made):
        made.bus.close()


def _player(w: World):
    pose, limits = w.pose_and_limits
    return dict(bus=w.bus, robot=w.motion.robot, clock=w.bus.clock, limits=limits)


def _sim_settings(_w: World):
    from choreo.preview.sim import SimSettings

    return SimSettings


def _check_thresholds(_w: World):
    from choreo.preview.findings import CheckThresholds

    return CheckThresholds


ANALYSIS = BeatAnalysis(1.0, (), (), 4, ())

# name -> (the callable, given the world; its valid keyword arguments)
CALLS = {
    "PlayOptions": (lambda w: PlayOptions, lambda w: {}),
    "PlanOptions": (lambda w: choreo.PlanOptions, lambda w: {}),
    "play_motion": (lambda w: play_motion, lambda w: dict(motion=w.motion, port=PORT)),
    "ServoBus": (lambda w: ServoBus, lambda w: dict(port=PORT)),
    "ServoBus.from_settings": (
        lambda w: ServoBus.from_settings,
        lambda w: dict(settings=BusSettings(port=PORT)),
    ),
    "ServoBus.move": (lambda w: w.bus.move, lambda w: dict(servo_id=1, pos_units=500, time_ms=0)),
    "ServoBus.presence": (lambda w: w.bus.presence, lambda w: dict(servo_id=1)),
    "ServoBus.set_led": (lambda w: w.bus.set_led, lambda w: dict(servo_id=1, on=True)),
    "ServoBus.scan": (lambda w: w.bus.scan, lambda w: dict(ids=[1])),
    "load_robot": (lambda w: choreo.load_robot, lambda w: dict(path_or_name="arm6")),
    "load_motion": (lambda w: load_motion, lambda w: dict(path=WAVE)),
    "plan_motion": (lambda w: plan_motion, lambda w: dict(motion=w.motion)),
    "compile_motion": (lambda w: compile_motion, lambda w: dict(motion=w.motion)),
    "prepare": (
        lambda w: choreo.prepare,
        lambda w: dict(compiled=w.compiled, start_pose_deg=[0.0] * 6),
    ),
    "plan_report": (
        lambda w: choreo.plan_report,
        lambda w: dict(motion=w.motion, compiled=w.compiled, speed=1.0),
    ),
    "RealClock": (lambda w: RealClock, lambda w: {}),
    "VirtualClock": (lambda w: VirtualClock, lambda w: {}),
    "VirtualClock.advance": (lambda w: VirtualClock().advance, lambda w: dict(dt_s=0.1)),
    "Player": (lambda w: choreo.Player, _player),
    "Player.play": (
        lambda w: w.player.play,
        lambda w: dict(ticks=w.performance.ticks, start_pose_deg=w.pose_and_limits[0]),
    ),
    "Player.leave": (lambda w: w.player.leave, lambda w: dict(outcome=choreo.Outcome.COMPLETED)),
    "preflight": (lambda w: choreo.preflight, lambda w: dict(bus=w.bus, robot=w.motion.robot)),
    "report_document": (lambda w: choreo.report_document, lambda w: dict(report=w.report)),
    "simulate_motion": (lambda w: choreo.simulate_motion, lambda w: dict(motion=w.motion)),
    "SimSettings": (_sim_settings, lambda w: {}),
    "run_checks": (lambda w: choreo.run_checks, lambda w: dict(rollout=w.rollout)),
    "CheckThresholds": (_check_thresholds, lambda w: {}),
    "preview_report": (
        lambda w: choreo.preview_report,
        lambda w: dict(rollout=w.rollout, results=[]),
    ),
    "decode_song": (lambda w: choreo.decode_song, lambda w: dict(path="song.wav")),
    "detect_beats": (lambda w: choreo.detect_beats, lambda w: dict(audio="song.wav")),
    "beats_report": (
        lambda w: choreo.beats_report,
        lambda w: dict(song="song.wav", analysis=ANALYSIS),
    ),
}

# name -> argument -> values it refuses, each with an OptionError naming the argument
REFUSED = {
    "PlayOptions": {
        "exit_mode": ["bogus", "POSE", 5, None],
        "exit_pose": NOT_TEXT + [None],
        "tolerance_deg": BOUNDED_BAD + [5.01],
        "speed": optional(POSITIVE_BAD),  # None: the file's speed
        "stretch": NOT_FLAGS,
        "loop": optional(WHOLE_BAD),  # None: the file's repeat
        "allow_past_song": NOT_FLAGS,
        "audio": NOT_FLAGS,
        "audio_device": NOT_TEXT,
        "audio_latency_s": optional(BOUNDED_BAD) + [2.01],
        "lead_s": NON_NEGATIVE_BOUNDED_BAD,
        "health_timeout_s": BOUNDED_BAD + [5.01],
        "start_guard_s": NON_NEGATIVE_BOUNDED_BAD,
        "max_missed_reads": WHOLE_BAD,
        "max_position_error_deg": BOUNDED_BAD,
        "temp_margin_c": NON_NEGATIVE_BOUNDED_BAD + [1.5, 101],
        "realtime": ["yes", 1, NAN],
    },
    "play_motion": {
        "motion": NOT_PATHS,
        "port": [123, 1.5, NAN, object()],
        "options": NOT_OPTIONS,
        "bus_settings": [{}, "sim://", 5],
        "open_audio": NOT_CALLABLE + [None],
        "on_progress": NOT_CALLABLE,
        "on_note": NOT_CALLABLE + [None],
    },
    "ServoBus": {
        "port": [5, 1.5, NAN, None, "", "  ", object()],
        "timeout_s": BOUNDED_BAD,
        "retries": NOT_NUMBERS + NOT_FINITE + [-1, 10, 1.5, 1e308],
        "echo": ["bogus", "AUTO", 5, None],
        "direction": [5, 1.5, NAN],
    },
    "ServoBus.from_settings": {
        "settings": [None, 5, "sim://", {"port": "sim://"}],
        "emulated": [None, 5, object()],
    },
    "ServoBus.move": {
        "servo_id": [-1, 255, 1.5, NAN, "1", None, 10**400],
        "pos_units": [-1, 1001, 500.0, NAN, INF, 10**400, "500"],
        "time_ms": [-1, 30001, 1.5, NAN, 1e308],
    },
    "ServoBus.presence": {"timeout_s": optional(BOUNDED_BAD), "retries": [-1, 10, 1.5, NAN, "1"]},
    "ServoBus.set_led": {"on": NOT_FLAGS},
    "ServoBus.scan": {"ids": [5, NAN, None]},
    "load_robot": {
        "path_or_name": NOT_PATHS,
        "relative_to": [5, NAN, ""],
        "with_figures": NOT_FLAGS,
    },
    "load_motion": {"path": NOT_PATHS, "allow_past_song": NOT_FLAGS},
    "plan_motion": {"motion": NOT_PATHS, "speed": optional(POSITIVE_BAD), "stretch": NOT_FLAGS},
    "PlanOptions": {
        "speed": optional(POSITIVE_BAD),
        "stretch": NOT_FLAGS,
        "tolerance_deg": BOUNDED_BAD + [5.01],
    },
    "compile_motion": {
        "motion": NOT_PATHS,
        "plan": [5, {}, "fast", PlayOptions()],
        "speed": optional(POSITIVE_BAD),
        "stretch": NOT_FLAGS,
        "tolerance_deg": BOUNDED_BAD + [5.01],
    },
    "prepare": {
        "compiled": [5, None, "wave.yaml", {}],
        "start_pose_deg": [
            5,
            None,
            "abc",
            [0.0] * 3,
            [NAN] * 6,
            [INF] * 6,
            [-INF] * 6,
            [1e308] * 6,
            [1e6] * 6,
            10**400,
            [10**400] * 6,
        ],
    },
    "plan_report": {
        "motion": [5, None, str(WAVE)],
        "compiled": [5, None],
        "speed": POSITIVE_BAD,
    },
    "RealClock": {"spin_s": NON_NEGATIVE_BOUNDED_BAD + [0.5]},
    "VirtualClock": {"start_s": NOT_NUMBERS + NOT_FINITE + [10**400]},
    "VirtualClock.advance": {"dt_s": NON_NEGATIVE_BAD},
    "Player": {
        "bus": [5, None, PORT],
        "robot": [5, None, "arm6"],
        "clock": [5, None, "virtual"],
        "limits": [5, None, {}, []],
        "options": NOT_OPTIONS,
        "on_progress": NOT_CALLABLE,
    },
    "Player.play": {
        "ticks": [5, None, "ticks", [1, 2]],
        "start_pose_deg": [5, None, "abc", [0.0] * 3, [NAN] * 6, [1e308] * 6, [10**400] * 6],
        "start_at_s": optional(NOT_NUMBERS) + NOT_FINITE + [10**400],
    },
    "Player.leave": {"outcome": [5, None, "bogus", "COMPLETED"]},
    "preflight": {"bus": [5, None, PORT], "robot": [5, None, "arm6"]},
    "report_document": {"report": [5, None, {}]},
    "simulate_motion": {
        "motion": NOT_PATHS,
        "settings": [{}, 5],
        "plan": [5, {}, PlayOptions()],
        "speed": optional(POSITIVE_BAD),
        "stretch": NOT_FLAGS,
        "tolerance_deg": BOUNDED_BAD + [5.01],
        "start_pose": NOT_TEXT + ["nope"],
    },
    "SimSettings": {
        "max_settle_s": NON_NEGATIVE_BOUNDED_BAD + [61],
        "move_start": ["bogus", 5, None],
        "tail_s": NON_NEGATIVE_BOUNDED_BAD + [61],
        "min_contact_depth_m": NON_NEGATIVE_BAD,
        "actuator_overrides": [5, "elbow", {"elbow": 5}, {"elbow": {"gain": 1}}]
        + [{"elbow": {"kp_nm_rad": value}} for value in POSITIVE_BAD],
    },
    "run_checks": {"rollout": [5, None], "thresholds": [{}, 5, None]},
    "CheckThresholds": {
        "max_tracking_error_deg": NON_NEGATIVE_BAD,
        "near_miss_fraction": NOT_NUMBERS + NOT_FINITE + NOT_POSITIVE + [1.01, 1e308],
        "stall_speed_fraction": NOT_NUMBERS + NOT_FINITE + NOT_POSITIVE + [1.01, 1e308],
        "fall_height_fraction": NOT_NUMBERS + NOT_FINITE + NOT_POSITIVE + [1.5, 10**400],
    },
    "preview_report": {
        "rollout": [5, None],
        "results": [5, None, [5]],
        "motion": NOT_TEXT,
        "thresholds": [{}, 5],
    },
    "decode_song": {
        "path": NOT_PATHS,
        "rate_hz": WHOLE_BAD + [7999, 22050.0, 10**400],
        "channels": WHOLE_BAD + [9],
    },
    "detect_beats": {
        "audio": NOT_PATHS,
        "beats_per_bar": optional(WHOLE_BAD),
        "level": ["bogus", "HALF", 5, None],
        "offset_beats": NOT_NUMBERS + NOT_FINITE + [10**400],
    },
    "beats_report": {
        "song": NOT_PATHS,
        "analysis": [5, None, {}],
        "level": ["bogus", 5, None],
        "offset_beats": NOT_NUMBERS + NOT_FINITE,
    },
}

# What the calls return, and enums: made by choreo and read by programs, never given checked
# arguments by them.
RESULTS = {
    "Audio",
    "BeatAnalysis",
    "CompiledMotion",
    "ExitMode",
    "Joint",
    "Keyframe",
    "Motion",
    "Outcome",
    "Performance",
    "PlanResult",
    "PlayReport",
    "Robot",
    "StreamReport",
    "SimulatedMotion",
    "Trajectory",
}


def _shown_id(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 20 else text[:17] + "..."


CASES = [
    pytest.param(name, option, value, id=f"{name}-{option}={_shown_id(value)}")
    for name, options in REFUSED.items()
    for option, values in options.items()
    for value in values
]


@pytest.mark.parametrize("name, option, value", CASES)
def test_a_bad_argument_is_refused_naming_it(world, name, option, value):
    call, valid = CALLS[name]
    with pytest.raises(OptionError) as refused:
        call(world)(**{**valid(world), option: value})
    assert refused.value.option == option
    message = str(refused.value)
    assert message.startswith(option)
    assert "\n" not in message and len(message) < 400  # one line: 10**400 is not spelled out


def test_every_public_name_is_walked_or_is_a_result():
    public = set(choreo.__all__) - {"__version__", *choreo.ERRORS}
    walked = {name.split(".")[0] for name in REFUSED}
    assert public - walked - RESULTS == set()
    assert set(REFUSED) == set(CALLS)


@pytest.mark.parametrize(
    "call, error, words",
    [
        (lambda: choreo.detect_beats("missing.wav"), ChoreoError, "missing.wav does not exist"),
        (lambda: ServoBus(PORT, direction="bogus"), OptionError, "direction 'bogus' is not a"),
        (lambda: ServoBus(Path("/dev/no-such-tty")), PortError, "/dev/no-such-tty"),
        (lambda: load_motion(REPO / "no-such.yaml"), ChoreoError, "no-such.yaml"),
    ],
    ids=["song-missing", "direction-unknown", "port-path-missing", "motion-missing"],
)
def test_an_argument_naming_what_is_not_there_is_a_choreo_error(call, error, words):
    with pytest.raises(error, match=words):
        call()


def test_the_issue_s_examples_each_say_what_was_given_and_what_would_do():
    refusals = {}
    for arguments in (
        dict(speed=0),
        dict(tolerance_deg=1e308),
        dict(loop=-1),
        dict(exit_mode="bogus"),
        dict(health_timeout_s=INF),
    ):
        with pytest.raises(OptionError) as refused:
            PlayOptions(**arguments)
        refusals[refused.value.option] = str(refused.value)
    assert refusals == {
        "speed": "speed must be a number >= 0.01 and <= 100, or None, got 0",
        "tolerance_deg": "tolerance_deg must be a number > 0 and <= 5°, got 1e+308",
        "loop": "loop must be a whole number >= 1, or None, got -1",
        "exit_mode": "exit_mode must be an ExitMode or one of its values 'hold', 'pose', "
        "'unload', got 'bogus'",
        "health_timeout_s": "health_timeout_s must be a number > 0 and <= 5 s, got inf",
    }


def test_a_dict_for_options_says_what_to_pass_instead():
    with pytest.raises(OptionError) as refused:
        play_motion(WAVE, PORT, options={"speed": 2})
    assert str(refused.value) == (
        "options must be a PlayOptions, e.g. PlayOptions(speed=2) (from a dict: "
        "PlayOptions(**options)), got dict {'speed': 2}"
    )


def test_the_largest_values_the_ranges_name_are_taken():
    options = PlayOptions(
        tolerance_deg=5, health_timeout_s=5, audio_latency_s=2, lead_s=0, temp_margin_c=100
    )
    assert (options.tolerance_deg, options.health_timeout_s) == (5, 5)
    assert RealClock(spin_s=0.1).spin_s == 0.1


def test_an_exit_mode_given_by_name_is_the_mode(world):
    options = PlayOptions(exit_mode="pose", exit_pose="home")
    assert options.exit_mode is ExitMode.POSE
    report = play_motion(world.motion, PORT, options)
    assert report.exit_move is not None  # it went to the exit pose


def test_compile_and_plan_take_a_motion_file_s_path_as_its_motion(world):
    for path in (WAVE, str(WAVE)):
        assert compile_motion(path).ticks == world.compiled.ticks
        assert plan_motion(path).trajectory.duration_s == world.compiled.trajectory.duration_s
