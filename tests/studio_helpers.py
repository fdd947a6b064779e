"""A studio on a copy of a shipped motion, without a browser, and what it said."""

from __future__ import annotations

import contextlib
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from paths import DATA, REPO

from choreo.core.atomic import write_text_atomically
from choreo.studio.address import Address
from choreo.studio.journal import Journal
from choreo.studio.server import Studio
from choreo.studio.session import file_digest

MOTIONS = REPO / "motions"
STUDIO_WAVE = DATA / "studio" / "wave.yaml"  # wave with groove.ogg beside it


WAVE = (MOTIONS / "arm6" / "wave.yaml").read_text()


def body_sway_rise() -> str:
    """motions/hexapod18/body_sway.yaml up to its first sway: home, the body 20 mm up, swayed
    one way (1.5 s of its 16). For tests of a walker's body: keyframes in the studio, which
    simulates all of a motion it loads (1.3 s of CPU for the whole dance, a walker's stance
    measured at every step)."""
    text = (MOTIONS / "hexapod18" / "body_sway.yaml").read_text()
    return text[: text.index("  - body: {z: 20, y: -25, roll: 6}\n")]


@contextlib.contextmanager
def studio_on(tmp_path: Path, motion: str, text: str | None = None) -> Iterator[Studio]:
    """A studio on a copy of ``motions/<motion>`` (its song beside it as in motions/), or on
    ``text`` saved in its place; ``studio.said`` is what it printed."""
    path = tmp_path / motion
    path.parent.mkdir(parents=True, exist_ok=True)
    if text is None:
        shutil.copy(MOTIONS / motion, path)
    else:
        path.write_text(text)
    shutil.copytree(MOTIONS / "songs", tmp_path / "songs", dirs_exist_ok=True)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append)
    studio.said = said  # type: ignore[attr-defined]
    studio.start()
    try:
        yield studio
    finally:
        studio.close()


RELOAD_WAIT_S = 30.0  # a reload after a save, simulated, on a busy machine


def shared_studio(motion: str, name: str):
    """Two fixtures, for a module's tests on ``motions/<motion>`` as shipped: ``name``, a studio
    on it as if just started (``as_new``), and behind it the module's one studio, started once
    (a start costs more than most tests' edits). Both go to module names, where pytest finds
    them: ``_wave, studio = shared_studio("arm6/wave.yaml", "studio")``."""
    text = (MOTIONS / motion).read_text()

    @pytest.fixture(scope="module", name=f"{name}_shared")
    def started(tmp_path_factory):
        with studio_on(tmp_path_factory.mktemp(name), motion) as studio:
            yield studio

    @pytest.fixture(name=name)
    def fresh(request):
        return as_new(request.getfixturevalue(f"{name}_shared"), text)

    return started, fresh


def as_new(studio: Studio, text: str) -> Studio:
    """``studio`` (shared by a module's tests: starting one costs more than most edits) as one
    started on ``text`` would be: its file ``text`` and the plan made from it, simulated;
    nothing selected, posed or to undo; the timeline at 0; nothing said."""
    session, path = studio.session, studio.session.motion_path
    if path.read_text() != text or session.plan_digest != file_digest(path):
        version = session.version
        write_text_atomically(path, text)  # the watcher reloads it (a reload of its own would
        # race the watcher's, whose lines could then come in the next test's)
        deadline = time.monotonic() + RELOAD_WAIT_S
        while not any(
            line.startswith(f"simulated {path}: ") and int(line.rsplit(" ", 1)[1]) > version
            for line in studio.said  # type: ignore[attr-defined]
        ):
            assert time.monotonic() < deadline, f"gave up waiting for {path} to reload"
            time.sleep(0.02)
        assert session.plan_digest == file_digest(path) and session.problems == ()
    studio.select_keyframe(None)
    studio.scrub(0.0)  # and the plan's pose, not a posed one
    studio.journal = Journal(path)
    studio.said.clear()  # type: ignore[attr-defined]
    return studio


def times(studio: Studio) -> list[float]:
    plan = studio.session.plan
    assert plan is not None
    return [round(t, 3) for t in plan.keyframe_times_s]


def refused(studio: Studio) -> str:
    """The studio's last line, which must be a refusal."""
    last = studio.said[-1]  # type: ignore[attr-defined]
    assert last.startswith("⛔ "), last
    return last


def copy_motion(path: Path) -> None:
    """tests/data/studio/wave.yaml and its song to ``path``'s folder."""
    shutil.copy(STUDIO_WAVE, path)
    shutil.copy(STUDIO_WAVE.with_name("groove.ogg"), path.with_name("groove.ogg"))
