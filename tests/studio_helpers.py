"""A studio on a copy of a shipped motion, without a browser, and what it said."""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterator
from pathlib import Path

from paths import DATA, REPO

from choreo.studio.address import Address
from choreo.studio.server import Studio

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
