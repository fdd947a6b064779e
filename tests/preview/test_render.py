"""choreo.preview rendering, offscreen. These tests render for real: where rendering is impossible
they fail (CI installs Mesa's EGL and OSMesa), they never skip."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np
import paths
import pytest
from cli_helpers import WAVE, usage_error_line
from emulated import wait_for
from paths import REPO
from PIL import Image
from render_helpers import mujoco_view
from shipped_helpers import simulated_shipped

from choreo.errors import PreviewError
from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import compile_ticks
from choreo.preview import (
    CheckKind,
    CheckResult,
    RenderSettings,
    Severity,
    SimSettings,
    frame_times,
    gl,
    render_frames,
    render_preview,
    run_checks,
    simulate_motion,
)
from choreo.preview.model import load_model
from choreo.preview.render import (
    CameraPose,
    FrameRenderer,
    _stop_signals_held,
    frame_camera,
    problem_text,
    status_text,
)
from choreo.robot.robot_file import load_robot

DATA = paths.DATA / "preview"
FINE = DATA / "motions" / "fine.yaml"


@pytest.fixture(scope="module")
def fine():
    """The arm3 test motion, its rollout, and how long the preview runs (from its ticks)."""
    motion = load_motion(FINE)
    ticks = compile_ticks(plan_motion(motion).trajectory, motion.robot).ticks
    return simulate_motion(motion).rollout, ticks[-1].end_ms / 1000 + SimSettings().tail_s


def video_frames(path: Path) -> np.ndarray:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return np.stack([np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader])


# --- MUJOCO_GL (the back-end's choice: test_gl.py) -------------------------------------------


def choreo_with_mujoco_gl(value: str, *argv: str) -> subprocess.CompletedProcess:
    """``choreo *argv`` in a process of its own (mujoco reads MUJOCO_GL when first imported)."""
    return subprocess.run(
        [sys.executable, "-m", "choreo", *argv],
        cwd=REPO,
        env={**os.environ, "MUJOCO_GL": value},
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_a_bad_mujoco_gl_stops_no_command_that_does_not_render():
    for argv in (["preview", str(FINE), "--check"], ["robots", "arm6"]):
        done = choreo_with_mujoco_gl("bogus", *argv)
        assert (done.returncode, done.stderr) == (0, ""), argv


def test_a_bad_mujoco_gl_stops_a_render_with_one_line(tmp_path):
    output = tmp_path / "sheet.png"
    done = choreo_with_mujoco_gl("bogus", "preview", str(FINE), "-o", str(output))
    assert done.returncode == 1
    assert done.stderr == (
        "choreo: error: MUJOCO_GL=bogus is not an OpenGL back-end to render with: set it to "
        "egl, osmesa or glfw, or unset it to use the first that works\n"
    )
    assert not output.exists()


def test_rendering_without_a_backend_is_an_error_not_a_skip(fine, tmp_path, monkeypatch):
    def unavailable():
        raise PreviewError("cannot render offscreen: no OpenGL back-end works")

    monkeypatch.setattr("choreo.preview.render.offscreen_backend", unavailable)
    with pytest.raises(PreviewError, match="cannot render offscreen"):
        render_preview(fine[0], tmp_path / "out.png", RenderSettings(64, 48))


# --- the files ---------------------------------------------------------------------------------


def test_an_mp4_has_one_frame_per_tick_of_the_clock_and_shows_the_robot_moving(fine, tmp_path):
    rollout, duration_s = fine
    fps = 12
    path = tmp_path / "fine.mp4"
    done = render_preview(rollout, path, RenderSettings(160, 120, fps=fps))
    # frames from the start of the settling before t = 0, every 1/fps, up to the end
    expected = int((duration_s - rollout.start_s) * fps + 1e-9) + 1
    assert done.frames == expected
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == expected
    frames = video_frames(path).astype(float)
    assert frames.shape == (expected, 120, 160, 3)
    assert min(frame.std() for frame in frames) > 10  # not blank

    # the arm is at home at 0 s and turned, leaning over at 1 s (fine.yaml's second keyframe):
    # the pixels it leaves and covers change, more than from one frame to the next
    def changed(a: int, b: int) -> float:
        return (np.abs(frames[a] - frames[b]).max(axis=2) > 30).mean()

    zero = int(math.ceil(-rollout.start_s * fps - 1e-9))  # the first frame of the motion
    assert changed(zero + fps, zero) > 0.005
    assert changed(zero + fps, zero) > 3 * changed(zero + 1, zero)


def test_a_gif_has_the_frames_and_their_timing(fine, tmp_path):
    rollout, duration_s = fine
    path = tmp_path / "fine.gif"
    render_preview(rollout, path, RenderSettings(96, 72, fps=10))
    with Image.open(path) as gif:
        assert gif.size == (96, 72)
        durations = []
        for k in range(gif.n_frames):  # identical frames are merged into one longer frame
            gif.seek(k)
            durations.append(gif.info["duration"])
    assert sum(durations) == 100 * (int(duration_s * 10) + 1)
    assert min(durations) == 100


def test_a_png_is_a_contact_sheet_across_the_motion(fine, tmp_path):
    rollout, _ = fine
    path = tmp_path / "sheet.png"
    assert render_preview(rollout, path, RenderSettings(160, 120, sheet_frames=6)).frames == 6
    sheet = np.asarray(Image.open(path).convert("RGB")).astype(float)
    gap = 4
    assert sheet.shape == (2 * 120 + gap, 4 * 160 + 3 * gap, 3)  # 4 columns, 2 rows
    tiles = [
        sheet[r * (120 + gap) : r * (120 + gap) + 120, c * (160 + gap) : c * (160 + gap) + 160]
        for r in range(2)
        for c in range(4)
    ]
    assert all(tile.std() > 10 for tile in tiles[:6])
    assert all((tile == 255).all() for tile in tiles[6:])  # unused places stay blank


def test_an_unknown_format_or_an_odd_mp4_size_is_refused(fine, tmp_path):
    with pytest.raises(ValueError, match="must end in .mp4, .gif, .png"):
        render_preview(fine[0], tmp_path / "out.avi")
    with pytest.raises(ValueError, match="mp4 needs an even width and height"):
        render_preview(fine[0], tmp_path / "out.mp4", RenderSettings(161, 120))


# --- what the frames show ----------------------------------------------------------------------


def test_the_overlay_gives_the_time_and_the_keyframe_reached(fine):
    rollout, _ = fine
    keyframes = rollout.keyframe_times_s
    assert len(keyframes) == 3 and keyframes[1] == pytest.approx(1.0)
    assert status_text(rollout, 0.0) == ("time\nkeyframe", "0.00 s\n1 / 3")
    assert status_text(rollout, 1.25) == ("time\nkeyframe", "1.25 s\n2 / 3")
    assert status_text(rollout, 2.4)[1].endswith("3 / 3")


def test_the_overlay_lists_the_problems_under_way():
    stall = CheckResult(CheckKind.SATURATION, Severity.ERROR, "...", 1.0, 0.8, joint="elbow")
    touch = CheckResult(
        CheckKind.SELF_COLLISION, Severity.ERROR, "...", 1.5, 0.0, bodies=("forearm", "base")
    )
    assert problem_text([stall, touch], 0.9) == ("", "")
    assert problem_text([stall, touch], 1.6) == (
        "error stall\nerror collision",
        "elbow\nforearm / base",
    )
    # the stall is over at 1.8 s; the instant touch stays on screen for 0.5 s
    assert problem_text([stall, touch], 1.9) == ("error collision", "forearm / base")
    assert problem_text([stall, touch], 2.1) == ("", "")


def test_the_overlay_is_drawn_on_the_frames(fine):
    rollout, _ = fine
    settings = RenderSettings(320, 240)
    plain, with_problem = (
        next(render_frames(rollout, np.array([0.0]), settings, results))
        for results in ((), [CheckResult(CheckKind.FALL, Severity.ERROR, "...", 0.0)])
    )
    corner = (slice(0, 50), slice(0, 160))
    bottom = (slice(200, 240), slice(0, 160))
    assert plain[corner].max() > 200  # white text on the dark box
    assert np.abs(plain[bottom].astype(int) - with_problem[bottom]).sum() > 1000


def swept_geom_points(model, rollout, every: int = 10) -> np.ndarray:
    data = mujoco.MjData(model)
    points = []
    for step in range(0, len(rollout.times_s), every):
        data.qpos[:] = rollout.qpos[step]
        mujoco.mj_kinematics(model, data)
        points.append(data.geom_xpos[model.geom_bodyid != 0])
    return np.concatenate(points)


@pytest.mark.parametrize(
    "motion_path, fill",
    [
        ("hexapod18/stand_up.yaml", 0.6),
        ("hexapod18/tripod_gait.yaml", 0.6),
        ("arm6/wave.yaml", 0.6),
    ],
)
def test_one_camera_frames_the_whole_motion_and_fills_the_picture(motion_path, fill):
    """Every geom centre over the whole rollout is inside MuJoCo's view of the camera, and
    what the robot sweeps spans most of the picture's width or height."""
    rollout = simulated_shipped(REPO / "motions" / motion_path).rollout
    model = load_model(rollout.robot, rollout.props)
    camera = frame_camera(model, rollout, 4 / 3)
    pos, right, up, forward, half_w, half_h = mujoco_view(model, camera, 4 / 3)
    seen = swept_geom_points(model, rollout) - pos
    depth = seen @ forward
    x, y = (seen @ right) / depth, (seen @ up) / depth
    assert (depth > 0).all()
    assert np.abs(x).max() <= half_w and np.abs(y).max() <= half_h
    assert max((x.max() - x.min()) / (2 * half_w), (y.max() - y.min()) / (2 * half_h)) > fill


def test_the_frames_show_the_settling_and_the_approach_marked():
    rollout = simulated_shipped(REPO / "motions" / "tonypi" / "squat.yaml").rollout
    assert rollout.start_s < rollout.approach_start_s < 0
    assert status_text(rollout, rollout.start_s)[1].splitlines()[1] == "settling"
    assert status_text(rollout, rollout.approach_start_s / 2)[0] == "time\nbefore"
    assert status_text(rollout, rollout.approach_start_s / 2)[1].endswith("approach")
    assert status_text(rollout, 0.0) == ("time\nkeyframe", "0.00 s\n1 / 1")


# --- the command line --------------------------------------------------------------------------


def test_frame_times_cover_the_whole_preview():
    assert frame_times(1.0, 10).tolist() == pytest.approx([k / 10 for k in range(11)])
    assert len(frame_times(2.55, 30)) == 77
    assert frame_times(0.0, 30).tolist() == [0.0]


def test_the_frames_are_the_recorded_states(fine):
    """A frame at a time shows the pose recorded then: render it again from a fresh model."""
    rollout, _ = fine
    t = 1.0
    frame = next(render_frames(rollout, np.array([t]), RenderSettings(64, 48)))
    again = next(render_frames(rollout, np.array([t]), RenderSettings(64, 48)))
    other = next(render_frames(rollout, np.array([0.0]), RenderSettings(64, 48)))
    assert (frame == again).all()
    assert not (frame == other).all()
    assert run_checks(rollout) == []


def test_ctrl_c_while_rendering_keeps_the_old_video(tmp_path):
    keep = tmp_path / "keep.mp4"
    keep.write_bytes(b"a good video")
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "preview", str(WAVE), "-o", str(keep), "--overwrite"],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # Ctrl-C reaches ffmpeg too: signal the whole group
    )
    try:

        def rendering():
            assert process.poll() is None, process.communicate()
            return bool(list(tmp_path.glob(".keep.mp4.*")))

        wait_for(rendering, "the video to be rendering")
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130
    assert err.decode().strip() == "choreo: interrupted"
    assert keep.read_bytes() == b"a good video"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.mp4"]


def test_preview_size_is_bounded(capsys):
    assert usage_error_line(capsys, ["preview", str(WAVE), "--size", "100000x100000"]) == (
        "choreo preview: error: argument --size: expected WIDTHxHEIGHT from 16x16 to "
        "8192x8192, e.g. 640x480, got '100000x100000'"
    )


def test_a_frame_larger_than_the_gl_allows_is_a_preview_error():
    """With the back-end this process renders with (PyOpenGL fixed its platform at the first
    render); the failed render context leaves the next frames rendered as before."""
    model = load_model(load_robot("arm6"))
    with pytest.raises(PreviewError) as raised:
        FrameRenderer(model, 1 << 20, 16, gl.offscreen_backend())
    assert re.fullmatch(
        r"cannot render 1048576x16 frames with (egl|osmesa): .+; try a smaller width/height",
        str(raised.value),
    ), str(raised.value)
    model = load_model(load_robot("arm6"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with FrameRenderer(model, 32, 24, gl.offscreen_backend()) as renderer:
        frame = renderer.render(data, CameraPose((0, 0, 0.1), 1.0, 140, -20), ("t", "0"), ("", ""))
    assert frame.shape == (24, 32, 3) and frame.std() > 0


def test_sigterm_during_a_render_leaves_no_temporary_behind(tmp_path):
    out = tmp_path / "fine.mp4"
    render = subprocess.Popen(
        [sys.executable, "-m", "choreo", "preview", str(FINE), "-o", str(out), "--fps", "120"],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert render.stdout is not None
    for line in render.stdout:  # the checks are printed before the render starts
        if " simulated, " in line:
            break
    while not any(p.suffix == ".mp4" for p in tmp_path.iterdir()):  # the temporary, being written
        time.sleep(0.01)
    render.send_signal(signal.SIGTERM)
    assert render.wait(timeout=60) == 130
    assert render.stderr is not None and render.stderr.read().endswith("choreo: interrupted\n")
    assert list(tmp_path.iterdir()) == []


def test_a_stop_while_ffmpeg_starts_arrives_once_it_is_started():
    """The window where a Ctrl-C used to leave ffmpeg running on its own (it then wrote the
    temporary video after choreo removed it)."""
    reached_the_end_of_the_block = False
    with pytest.raises(KeyboardInterrupt):
        with _stop_signals_held():
            signal.raise_signal(signal.SIGINT)
            reached_the_end_of_the_block = True
    assert reached_the_end_of_the_block
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # as it was
