"""Fixtures shared by several test files."""

# ruff: noqa: E402 (OpenBLAS's threads are set before anything imports numpy)
from __future__ import annotations

import importlib.util
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path

# OpenBLAS's threads wait for work spinning: on the 2 cores the suite shares with its other
# worker (and the CPU hogs it is measured beside) a small matrix product then took 25 ms of CPU
# instead of 1.7 (librosa's mel spectrogram, 40 % of a beat detection's CPU). One thread each,
# in the workers and in the `choreo` processes the tests start (they inherit it): the results
# differ in their last bits at most, as they do between machines with more or fewer cores. Set
# before anything imports numpy (nothing above does). A value the user set is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# Mesa's software renderer (llvmpipe) hands each frame's tiles to threads of its own, a thread a
# core: for a preview's small frames, most of them the backdrop laid over (backdrop.py), handing
# over costs more than it saves, and its threads only compete with the other worker here. Drawn
# in the rendering thread, the README's dance preview took ~20 % less CPU to render (2.6 -> 2.2 s),
# every frame the same bytes (llvmpipe draws each tile alike whichever thread draws it). For the
# workers and the `choreo` processes the tests start; read when Mesa starts, so set before any
# test renders. A value the user set is kept.
os.environ.setdefault("LP_NUM_THREADS", "0")

import browser
import bytecode
import hypothesis
import offscreen_gl
import pytest
from emulated import built_in_emulator_in_virtual_time, home_specs, served_on_a_pty

from choreo.core.clock import RealClock
from choreo.emulator import BusEmulator
from choreo.robot.robot_file import load_robot

# The property tests draw the same examples on every run (seeded from each test's own code), so
# the README's test command gives a new user, and CI, what it gave whoever last changed the test:
# a random draw had found, once in ~1,300 arm poses, a reachable one the IK misses by 1.5 mm, and
# one CI run in ~30 would have failed on it. HYPOTHESIS_PROFILE=explore draws new examples.
hypothesis.settings.register_profile("repeatable", derandomize=True)
hypothesis.settings.register_profile("explore", derandomize=False)
hypothesis.settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


def _user_cache_dir() -> Path:
    """Where this user's caches go: XDG on Linux, the platform's own place elsewhere."""
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        return Path(os.environ["LOCALAPPDATA"])
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


# numba keeps librosa's compiled functions next to librosa's files, so a fresh virtual
# environment (as .ci/run makes) compiles them all again: about 35 s of CPU per run, against 5 s
# with the cache warm. Kept in the user's cache directory instead, they outlive the environment
# (numba checks each source file's content, and keys the cache by its directory: .ci/run makes
# its environment at the same path each time). Set before anything imports numba (nothing above
# does), which reads it once; the `choreo` processes the tests start inherit it. A
# NUMBA_CACHE_DIR the user set is kept.
os.environ.setdefault("NUMBA_CACHE_DIR", str(_user_cache_dir() / "choreo" / "numba"))

# A suite started in the background of a non-interactive shell (`pytest &`, some CI runners)
# inherits SIGINT ignored, and so would every `choreo` it starts: the tests that stop one with
# Ctrl-C would then watch it play to the end. Ctrl-C is what they test, so restore it.
signal.signal(signal.SIGINT, signal.default_int_handler)

# The files whose tests call librosa run on one worker of a parallel run (`-n auto`), which then
# pays librosa's import and numba's compiling (5 s, 9 s on a loaded machine) once, not on each.
# Named by their path from the repository (as in the tests' ids): two folders hold a test_report.py.
LIBROSA_FILES = (
    "tests/music/test_beats.py",
    "tests/music/test_report.py",
    "tests/motion/test_music_block.py",
    "tests/cli/test_music_commands.py",
    "tests/music/test_neural.py",
    "tests/music/test_tempo.py",
    "tests/music/test_tracker.py",
    "tests/test_docs.py",
)

# The files that check the shipped motions' simulations (seconds each) run on one worker too, which
# then simulates each motion once for all of them (shipped_helpers.simulated_shipped).
SHIPPED_SIMULATION_FILES = (
    "tests/preview/test_preview_shipped.py",
    "tests/preview/test_render.py",
    "tests/preview/test_render_follow.py",
    "tests/preview/test_start.py",
    "tests/preview/test_travel.py",
    "tests/preview/test_walk.py",
    "tests/robot/test_models.py",  # loads every shipped motion too
)

# The README's previews each render (its video of the tonypi dance: 11 s of CPU) and need no
# librosa: each is a unit of its own, so they spread over the workers instead of adding to the
# librosa files' worker.
OWN_UNITS = ("tests/test_docs.py::test_readme_command_runs[choreo preview ",)

# The costliest units, costliest first (by their wall time with -n 2 on a busy 2-core machine): a
# parallel run hands them out first, and the many short files fill in around them, so no long unit
# starts last and leaves the other worker idle (xdist's own order, by number of tests, starts with
# the files of hundreds of quick tests). Units not named keep that order, after these.
COSTLIEST_FIRST = (
    "tests/cli/test_show_commands.py",
    "tests/studio/test_timeline_page_browser.py",
    "librosa",
    "shipped simulations",
    "tests/studio/test_studio_browser.py",
    "tests/studio/test_editing.py",
    "tests/show/test_netns.py",
    OWN_UNITS[0],  # the README's previews
    "tests/identify/test_identify.py",
    "tests/robot/test_kinematics.py",
    "tests/preview/test_render.py",
    "tests/preview/test_twin.py",
)


def _cost_rank(unit: str) -> int:
    """A unit's place in COSTLIEST_FIRST (by the name a unit of its own starts with), or after."""
    for rank, name in enumerate(COSTLIEST_FIRST):
        if unit == name or (name in OWN_UNITS and unit.startswith(name)):
            return rank
    return len(COSTLIEST_FIRST)


if importlib.util.find_spec("xdist") is not None:  # hooks pytest knows only with xdist

    def pytest_xdist_auto_num_workers(config):
        """``-n auto``: one worker more than the cores. About a third of the suite's wall time
        is spent waiting (on choreo processes starting, shows playing in real time, Chromium
        drawing), and with a worker per core a core stands idle through each of those waits."""
        if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
            return None  # the count the user set: xdist's own hook reads it
        return len(os.sched_getaffinity(0)) + 1

    def pytest_xdist_make_scheduler(config, log):
        """``--dist loadfile`` (the default here), with the librosa files as one unit, the shipped
        simulations' files as another, the OWN_UNITS tests one each, and the costliest first."""
        if config.getoption("dist") != "loadfile":
            return None
        from xdist.scheduler import LoadFileScheduling

        class ByFileCostliestFirst(LoadFileScheduling):
            def _split_scope(self, nodeid: str) -> str:
                if nodeid.startswith(OWN_UNITS):
                    return nodeid
                file = super()._split_scope(nodeid)
                if file in LIBROSA_FILES:
                    return "librosa"
                return "shipped simulations" if file in SHIPPED_SIMULATION_FILES else file

            def _assign_work_unit(self, node) -> None:
                costliest = min(self.workqueue, key=_cost_rank)  # the first of equal rank
                self.workqueue.move_to_end(costliest, last=False)
                super()._assign_work_unit(node)

        return ByFileCostliestFirst(config, log)


# The tests that drive Chromium are the files named test_*_browser.py
BROWSER_TESTS = sorted(Path(__file__).parent.rglob("test_*_browser.py"))


_OWN_CACHE = pytest.StashKey[pytest.MonkeyPatch]()


def pytest_configure(config):
    """The run's own cache folder (passed model checks, gait calibrations, the OpenGL back-end
    that works): none of the user's is read, nor written, and every run starts empty. Made
    before anything renders or any worker starts, so that the workers of a parallel run and the
    commands tests start all share it: the back-end is tried once a run, not once a process."""
    if hasattr(config, "workerinput"):
        return  # a worker of a parallel run: it inherited the folder
    patch = config.stash[_OWN_CACHE] = pytest.MonkeyPatch()
    patch.setenv("CHOREO_CACHE_DIR", tempfile.mkdtemp(prefix="choreo-tests-cache-"))


def pytest_sessionstart(session):
    """What the suite needs from the machine, found or installed before any test runs, once (not
    in each xdist worker): offscreen OpenGL, and the browser when the browser tests are among
    those asked for. Where one cannot be had, the run stops with one line naming what to run.
    Then, for the workers of a parallel run, the modules they all import, compiled once."""
    config = session.config
    if hasattr(config, "workerinput"):
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    say = reporter.write_line if reporter is not None else print
    try:
        offscreen_gl.provide(say)
        if any(_asks_for(config, test_file) for test_file in BROWSER_TESTS):
            browser.provide(say)
    except (offscreen_gl.NoOffscreenGL, browser.NoBrowser) as missing:
        pytest.exit(str(missing), returncode=pytest.ExitCode.USAGE_ERROR)
    if bytecode.worth_compiling(config):  # before xdist starts the workers (its hook runs last)
        tests = Path(__file__).parent
        config.stash[_COMPILED] = bytecode.compile_once(
            config, tests.parent / "choreo", tests, _asked(config)
        )


_COMPILED = pytest.StashKey[list[Path]]()


def pytest_unconfigure(config):
    bytecode.remove(config.stash.get(_COMPILED, []))
    patch = config.stash.get(_OWN_CACHE, None)
    if patch is not None:
        shutil.rmtree(os.environ["CHOREO_CACHE_DIR"], ignore_errors=True)
        patch.undo()


def _asks_for(config, test_file: Path) -> bool:
    """Whether the run's arguments (or the configured testpaths, without any) include a file."""
    return any(path == test_file or path in test_file.parents for path in _asked(config))


def _asked(config) -> list[Path]:
    """The files and folders the run's arguments name (or the configured testpaths)."""
    asked = config.args or [str(config.rootpath / path) for path in config.getini("testpaths")]
    here = config.invocation_params.dir
    return [(here / argument.split("::", 1)[0]).resolve() for argument in asked]


@pytest.fixture
def arm_on_a_pty(tmp_path):
    """arm6's servos at home, on a pty served in real time: (emulator, link path)."""
    emulator = BusEmulator(home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyARM") as link:
        yield emulator, link


@pytest.fixture
def virtual_built_in_emulator(monkeypatch) -> list[BusEmulator]:
    """Commands without --port play on the built-in emulator on a virtual clock (their subject
    isn't timing); the emulators made, in order, so a test can read their clocks and logs."""
    from choreo.play import robot_bus

    made: list[BusEmulator] = []

    def built_in_emulator(robot):
        made.append(built_in_emulator_in_virtual_time(robot))
        return made[-1]

    monkeypatch.setattr(robot_bus, "built_in_emulator", built_in_emulator)
    return made


@pytest.fixture(scope="session")
def warm_librosa() -> None:
    """librosa's import and numba's first calls (15 s on a loaded machine), paid once per session
    in a fixture's setup, outside the timed tests: beats of two seconds of clicks."""
    from music_helpers import click_track, steady_times

    from choreo.music.beats import detect_beats

    detect_beats(click_track(steady_times(120, 0.25, 2.0), 2.0))
