"""choreo studio: what an edit from the page costs, now that each one is loaded and planned
before it is written (and, when it would not plan, the nearest time that works searched with up
to NEAREST_PLANS plans).

  add        Add keyframe between two keyframes, through the studio as the page calls it: from
             the click to the file written (the check's load and plan included), not counting
             the reload that follows (as a save in an editor).
  refused    an Add that would not plan: from the click to the refusal naming the nearest time
             that works (or that none of those tried does).
  undo       Undo of that add: the file put back.

For an arm6 motion of 30 s and one of 5 minutes (a keyframe a second, timed with t:).
Run: python benchmarks/bench_studio_edits.py
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

from choreo.studio.address import Address
from choreo.studio.server import Studio

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_studio import motion_text  # noqa: E402

REPEATS = 5


def timed(action) -> tuple[float, object]:
    began = time.perf_counter()
    result = action()
    return time.perf_counter() - began, result


def measure(folder: Path, duration_s: int) -> dict[str, list[float]]:
    path = folder / f"sway_{duration_s}.yaml"
    path.write_text(motion_text(duration_s))
    studio = Studio(path, Address("127.0.0.1", 0), say=lambda line: None)
    studio.start()
    figures: dict[str, list[float]] = {"add": [], "refused": [], "undo": []}
    try:
        for _ in range(REPEATS):
            studio.scrub(duration_s / 2 + 0.5)  # halfway between two keyframes
            studio.move_joint("gripper", 5)  # a small move: it plans
            took_s, written = timed(lambda: studio._write(studio._adding, "added a keyframe"))
            assert written, "the add was refused"
            figures["add"].append(took_s)
            figures["undo"].append(timed(studio.journal.undo)[0])
            studio.reload()
            studio.scrub(duration_s / 2 + 0.1)  # 0.1 s after a keyframe: too far for the base
            studio.move_joint("base_yaw", 90)
            took_s, written = timed(lambda: studio._write(studio._adding, "added a keyframe"))
            assert not written, "the add that should not plan was written"
            figures["refused"].append(took_s)
    finally:
        studio.close()
    return figures


def main() -> None:
    print(__doc__.split("\n\n")[0])
    with tempfile.TemporaryDirectory() as folder:
        for duration_s in (30, 300):
            figures = measure(Path(folder), duration_s)
            for name, values in figures.items():
                print(
                    f"{duration_s:4d} s motion  {name:8s} median {statistics.median(values):.2f} s"
                    f"  max {max(values):.2f} s  ({len(values)} runs)"
                )


if __name__ == "__main__":
    main()
