"""How fast the preview runs: hexapod physics without rendering (target: >= 20x real time) and
offscreen rendering at 640x480 (target: >= 20 frames/s, mp4 encoding included). The simulated
time counts everything simulated: settling, the approach and the motion. Rendering also says
the CPU a frame takes (Mesa's threads and ffmpeg included), which a busy machine changes less
than the frames a second.

    PYTHONPATH=. python benchmarks/bench_preview.py [--repeat N]
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.preview import (
    RenderSettings,
    render_frames,
    render_preview,
    run_checks,
    simulate,
    simulate_motion,
    start_pose_deg,
)
from choreo.preview.gl import offscreen_backend
from choreo.preview.render import frame_times

REPO = Path(__file__).resolve().parents[1]
HEXAPOD_MOTIONS = sorted((REPO / "motions" / "hexapod18").glob("*.yaml"))
RENDERED = REPO / "motions" / "hexapod18" / "tripod_gait.yaml"


def physics(repeat: int) -> None:
    print("hexapod physics, no rendering (planning and compiling the ticks not timed):")
    for path in HEXAPOD_MOTIONS:
        motion = load_motion(path)
        compiled = compile_motion(motion)
        start = start_pose_deg(motion, compiled.trajectory.at(0.0)[0], None)
        performance = prepare(compiled, start)
        best = np.inf
        for _ in range(repeat):
            started = time.perf_counter()
            rollout = simulate(
                motion.robot,
                performance.ticks,
                start,
                keyframe_times_s=compiled.trajectory.keyframe_times_s,
                motion_start_s=performance.approach_s,
                posture=motion.start,
                props=motion.props,
            )
            run_checks(rollout)
            best = min(best, time.perf_counter() - started)
        simulated = rollout.duration_s - rollout.start_s
        print(
            f"  {path.stem:16s} {simulated:5.2f} s simulated in {best * 1000:6.1f} ms: "
            f"{simulated / best:5.1f}x real time ({len(rollout.times_s)} steps, "
            f"{best / len(rollout.times_s) * 1e6:.0f} us/step, model load and checks included)"
        )


def cpu_s() -> float:
    """The CPU this process and its finished children (ffmpeg) have used."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def rendering(repeat: int) -> None:
    rollout = simulate_motion(load_motion(RENDERED)).rollout
    started = time.perf_counter()
    backend = offscreen_backend()
    print(f"offscreen back-end: {backend} (chosen in {time.perf_counter() - started:.2f} s)")
    settings = RenderSettings(640, 480)
    times = rollout.start_s + frame_times(rollout.duration_s - rollout.start_s, 30)
    best_frames = best_mp4 = cpu_frames = cpu_mp4 = np.inf
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(repeat):
            started, cpu = time.perf_counter(), cpu_s()
            for _frame in render_frames(rollout, times, settings):
                pass
            best_frames = min(best_frames, time.perf_counter() - started)
            cpu_frames = min(cpu_frames, cpu_s() - cpu)
            started, cpu = time.perf_counter(), cpu_s()
            render_preview(rollout, Path(folder) / "bench.mp4", settings)
            best_mp4 = min(best_mp4, time.perf_counter() - started)
            cpu_mp4 = min(cpu_mp4, cpu_s() - cpu)
    n = len(times)
    print(f"rendering {RENDERED.stem} at 640x480, {n} frames (set-up included):")
    print(
        f"  frames only      {n / best_frames:5.1f} frames/s ({best_frames:.2f} s), "
        f"{cpu_frames / n * 1000:.1f} ms of CPU a frame"
    )
    print(
        f"  mp4 (+ encoding) {n / best_mp4:5.1f} frames/s ({best_mp4:.2f} s), "
        f"{cpu_mp4 / n * 1000:.1f} ms of CPU a frame"
    )
    best_hq = np.inf
    for _ in range(repeat):
        started = time.perf_counter()
        for _frame in render_frames(
            rollout, times[:20], RenderSettings(640, 480, high_quality=True)
        ):
            pass
        best_hq = min(best_hq, time.perf_counter() - started)
    print(f"  --hq frames only {20 / best_hq:5.1f} frames/s (shadows, reflections, 4x MSAA)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    args = parser.parse_args()
    physics(args.repeat)
    rendering(args.repeat)


if __name__ == "__main__":
    main()
