"""Offscreen rendering of a rollout: mp4, gif, or a png contact sheet.

Frames replay the recorded states (``Rollout.qpos``), the settling and the approach before the
motion included; a fixed camera frames everything the robot reaches over the whole rollout (so
it neither bobs with the body nor leaves a fixed arm small; a robot walking far is followed
instead), and every frame carries the time, the phase (settling, approach, motion), the keyframe
index and the problems found at that moment.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from choreo.errors import PreviewError
from choreo.motion.music_block import BeatGrid, Music
from choreo.music.decode import add_song_to_video
from choreo.preview.backdrop import Backdrop
from choreo.preview.findings import CheckKind, CheckResult
from choreo.preview.floor import draw_infinite_planes_finite
from choreo.preview.gl import forget_remembered, give_back, offscreen_backend, take_context
from choreo.preview.model import load_model
from choreo.preview.rollout import Rollout
from choreo.preview.simulated import SimulatedMotion, rollout_of

log = logging.getLogger(__name__)

FORMATS = (".mp4", ".gif", ".png")
DEFAULT_FPS = {".mp4": 30.0, ".gif": 25.0, ".png": 30.0}
SHEET_COLUMNS = 4
PROBLEM_SHOWN_S = 0.5  # a problem shorter than this stays on screen this long
FRAME_MARGIN = 1.12  # the framed volume fills this much less than the whole picture
CAMERA_SAMPLES = 120  # robot states sampled to find the volume it sweeps
FOLLOW_WHEN = 1.15  # framing the whole path needs this much farther than the robot alone: follow
FOLLOW_SMOOTHING_S = 1.0  # the followed path, averaged over this long
UNIT_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
SHORT_NAMES = {
    CheckKind.SELF_COLLISION: "collision",
    CheckKind.FLOOR_CONTACT: "floor",
    CheckKind.JOINT_LIMIT: "limit",
    CheckKind.SATURATION: "stall",
    CheckKind.CANT_KEEP_UP: "can't keep up",
    CheckKind.NEAR_MISS: "near miss",
    CheckKind.NEIGHBOUR_CONTACT: "overlap",
    CheckKind.TRACKING_ERROR: "tracking",
    CheckKind.FALL: "fall",
    CheckKind.PROP: "prop",
    CheckKind.REACH: "reach",
    CheckKind.JOINT_JUMP: "joint jump",
    CheckKind.GAIT: "gait",
}

ProgressCallback = Callable[[int, int], None]  # (frames done, frames in all)


@dataclass(frozen=True)
class RenderSettings:
    width: int = 640
    height: int = 480
    fps: float | None = None  # None: 30 for mp4, 25 for gif
    sheet_frames: int = 12  # png contact sheet: this many frames across the motion
    # False: no shadows, reflections, haze or anti-aliasing, which cost Mesa's software renderer
    # 5-10x (640x480: ~45 instead of ~4 frames/s)
    high_quality: bool = False

    def __post_init__(self) -> None:
        if self.width < 16 or self.height < 16:
            raise ValueError(f"image size must be at least 16x16, got {self.width}x{self.height}")
        if self.fps is not None and not (math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be > 0, got {self.fps!r}")
        if self.sheet_frames < 1:
            raise ValueError(f"sheet_frames must be >= 1, got {self.sheet_frames}")


@dataclass(frozen=True)
class RenderResult:
    path: Path
    frames: int
    backend: str  # egl or osmesa


def frame_times(duration_s: float, fps: float) -> np.ndarray:
    """Frame k shows time k/fps, for every k with k/fps <= duration_s."""
    return np.arange(int(math.floor(duration_s * fps + 1e-9)) + 1) / fps


def render_preview(
    rollout: SimulatedMotion | Rollout,
    path: str | Path,
    settings: RenderSettings = RenderSettings(),
    results: Sequence[CheckResult] = (),
    on_frame: ProgressCallback | None = None,
    music: Music | None = None,
) -> RenderResult:
    """Render ``rollout`` (``simulate_motion``'s, or ``simulate``'s) to ``path`` (.mp4, .gif, or
    .png = a contact sheet). With ``music`` every frame shows its bar and beat, and an mp4
    carries the song, ``music.start_s`` of it at the motion's t=0."""
    recorded = rollout_of(rollout)
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"cannot render to {path.name}: the file must end in {', '.join(FORMATS)}")
    if suffix == ".mp4" and (settings.width % 2 or settings.height % 2):
        raise ValueError(
            f"mp4 needs an even width and height, got {settings.width}x{settings.height}"
        )
    fps = settings.fps or DEFAULT_FPS[suffix]
    if suffix == ".png":
        times = np.linspace(recorded.start_s, recorded.duration_s, settings.sheet_frames)
    else:
        times = recorded.start_s + frame_times(recorded.duration_s - recorded.start_s, fps)
    backend = offscreen_backend()
    grid = music.grid if music is not None else None
    frames = render_frames(recorded, times, settings, results, backend, on_frame, grid)
    if suffix == ".mp4":
        _write_mp4(path, frames, fps, settings)
        if music is not None:
            # the video opens at the rollout's start (settling, approach): the song's start
            # (music.start_s) is heard at the motion's t=0
            add_song_to_video(path, music.song, music.start_s + times[0], len(times) / fps)
    elif suffix == ".gif":
        _write_gif(path, frames, fps)
    else:
        _write_sheet(path, frames, len(times))
    return RenderResult(path, len(times), backend)


def render_frames(
    rollout: Rollout,
    times_s: np.ndarray,
    settings: RenderSettings,
    results: Sequence[CheckResult] = (),
    backend: str | None = None,
    on_frame: ProgressCallback | None = None,
    grid: BeatGrid | None = None,
) -> Iterator[np.ndarray]:
    """The frames (height, width, 3) uint8 at ``times_s``, one at a time."""
    model = load_model(rollout.robot, rollout.props)
    data = mujoco.MjData(model)
    steps = np.clip(np.searchsorted(rollout.times_s, times_s - 1e-9), 0, len(rollout.times_s) - 1)
    cameras = frame_cameras(model, rollout, settings.width / settings.height, steps)
    with FrameRenderer(
        model,
        settings.width,
        settings.height,
        backend or offscreen_backend(),
        settings.high_quality,
    ) as renderer:
        for k, step in enumerate(steps):
            data.qpos[:] = rollout.qpos[step]
            mujoco.mj_forward(model, data)
            t = float(times_s[k])
            yield renderer.render(
                data, cameras[k], status_text(rollout, t, grid), problem_text(results, t)
            )
            if on_frame is not None:
                on_frame(k + 1, len(steps))


def status_text(rollout: Rollout, t: float, grid: BeatGrid | None = None) -> tuple[str, str]:
    """The overlay's (names, values) columns at time ``t``: the time, the phase (before the
    motion: settling or approach), the keyframe index (of the keyframe last reached, counting
    from 1) and, with music, the bar and beat under way (before beat 1: a count-in of the beats
    to come, at the first beats' interval)."""
    names, values = ["time"], [f"{t:.2f} s"]
    phase = rollout.phase(t)
    if phase != "motion":
        names.append("before")
        values.append(phase)
    keyframes = rollout.keyframe_times_s
    if keyframes and phase == "motion":
        reached = int(np.searchsorted(keyframes, t + 1e-9, side="right"))
        names.append("keyframe")
        values.append(f"{max(reached, 1)} / {len(keyframes)}")
    if grid is not None and grid.beats:
        first = grid.beat_times_s[0]
        if t < first - 1e-6:  # before beat 1 (settling, approach): the beats still to come
            interval = grid.beat_times_s[1] - first if grid.beats > 1 else 0.5
            names.append("count-in")
            values.append(f"{math.ceil((first - t) / interval - 1e-6)}")
        else:
            bar, beat = grid.bar_and_beat(math.floor(grid.beat_at(t) + 1e-6))
            names.append("bar / beat")
            values.append(f"{bar} / {beat:g}")
    return "\n".join(names), "\n".join(values)


def problem_text(results: Sequence[CheckResult], t: float) -> tuple[str, str]:
    """The overlay's (problems, where) columns at time ``t``: every problem under way."""
    shown = [
        r for r in results if r.time_s <= t + 1e-9 <= r.time_s + max(r.duration_s, PROBLEM_SHOWN_S)
    ]
    kinds = [f"{r.severity.value} {SHORT_NAMES[r.kind]}" for r in shown]
    where = [r.joint or " / ".join(r.bodies) for r in shown]
    return "\n".join(kinds), "\n".join(where)


@dataclass(frozen=True)
class CameraPose:
    lookat: tuple[float, float, float]
    distance: float
    azimuth: float
    elevation: float


def frame_camera(model: mujoco.MjModel, rollout: Rollout, aspect: float) -> CameraPose:
    """One camera for the whole rollout, at the model's azimuth and elevation, aimed at the
    middle of what the robot sweeps (every geom's bounding box over the whole rollout, props
    included) and just close enough for all of it to fit the picture."""
    return _fit(model, _swept_corners(model, rollout), aspect)


def frame_cameras(
    model: mujoco.MjModel, rollout: Rollout, aspect: float, steps: np.ndarray
) -> list[CameraPose]:
    """The camera at each of ``steps``: ``frame_camera``'s, unless the robot walks so far that
    framing its whole path would leave it small (``FOLLOW_WHEN``); then a camera that frames
    the robot alone and follows its body across the floor, its path smoothed over
    ``FOLLOW_SMOOTHING_S`` (so it glides, neither bobbing nor swaying with the steps)."""
    fixed = frame_camera(model, rollout, aspect)
    if rollout.body is None or len(rollout.times_s) < 2:
        return [fixed] * len(steps)
    dt = float(rollout.times_s[1] - rollout.times_s[0])
    address = rollout.body.qpos_address
    path = _smoothed(rollout.qpos[:, address : address + 2], round(FOLLOW_SMOOTHING_S / dt))
    sampled, corners = _robot_corners(model, rollout)
    corners[..., :2] -= path[sampled][:, None, :]  # the robot as seen from its smoothed path
    own = _fit(model, corners.reshape(-1, 3), aspect)
    if fixed.distance <= FOLLOW_WHEN * own.distance:
        return [fixed] * len(steps)
    x, y, z = own.lookat
    return [dataclasses.replace(own, lookat=(x + path[s, 0], y + path[s, 1], z)) for s in steps]


def _smoothed(path: np.ndarray, window: int) -> np.ndarray:
    """A moving average of each column over ``window`` rows, the ends held."""
    if window <= 1:
        return path.copy()
    padded = np.pad(path, ((window // 2, window - 1 - window // 2), (0, 0)), mode="edge")
    kernel = np.ones(window) / window
    return np.stack([np.convolve(padded[:, c], kernel, mode="valid") for c in range(2)], axis=1)


def _fit(model: mujoco.MjModel, points: np.ndarray, aspect: float) -> CameraPose:
    """The camera at the model's azimuth and elevation aimed at the middle of ``points`` and
    just close enough for all of them to fit the picture."""
    azimuth, elevation = float(model.vis.global_.azimuth), float(model.vis.global_.elevation)
    axes = np.stack(_camera_axes(azimuth, elevation))  # right, up, forward
    seen = points @ axes.T  # each point in camera axes
    low, high = seen.min(axis=0), seen.max(axis=0)
    middle = (low + high) / 2
    tan_v = math.tan(math.radians(model.vis.global_.fovy) / 2)
    tan_h = tan_v * aspect
    offset = seen - middle
    # a point at depth d beyond the look-at point is seen at distance D + d: it fits when
    # |x| <= (D + d) tan(half the field of view)
    needed = np.maximum(np.abs(offset[:, 0]) / tan_h, np.abs(offset[:, 1]) / tan_v)
    distance = float(np.max(needed * FRAME_MARGIN - offset[:, 2]))
    x, y, z = (float(c) for c in middle @ axes)
    return CameraPose((x, y, z), max(distance, 1e-3), azimuth, elevation)


def _camera_axes(azimuth_deg: float, elevation_deg: float):
    """MuJoCo's free camera: looking along ``forward`` (azimuth about z from +x, elevation
    negative looking down)."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.array([math.sin(az), -math.cos(az), 0.0])
    up = np.cross(right, forward)
    return right, up, forward


def _swept_corners(model: mujoco.MjModel, rollout: Rollout) -> np.ndarray:
    """The world corners of every robot geom's bounding box at sampled steps, and the props'."""
    _, corners = _robot_corners(model, rollout)
    points = [corners.reshape(-1, 3)]
    prop_names = {p.name for p in rollout.props}
    props = np.array(
        [
            g
            for g in range(model.ngeom)
            if not model.geom_bodyid[g] and model.geom(g).name in prop_names
        ],
        dtype=int,
    )
    if len(props):
        data = mujoco.MjData(model)
        data.qpos[:] = rollout.qpos[-1]
        mujoco.mj_kinematics(model, data)
        points.append(_geom_corners(model, data, props, UNIT_CORNERS))
    return np.concatenate(points)


def _robot_corners(model: mujoco.MjModel, rollout: Rollout) -> tuple[np.ndarray, np.ndarray]:
    """Sampled steps, and at each the world corners of every geom's bounding box that is not
    the world's (the robot's, and free props'): (steps,), (steps, corners, 3)."""
    data = mujoco.MjData(model)
    geoms = np.flatnonzero(model.geom_bodyid != 0)
    steps = np.unique(np.linspace(0, len(rollout.times_s) - 1, CAMERA_SAMPLES).astype(int))
    corners = []
    for step in steps:
        data.qpos[:] = rollout.qpos[step]
        mujoco.mj_kinematics(model, data)
        corners.append(_geom_corners(model, data, geoms, UNIT_CORNERS))
    return steps, np.array(corners)


def _geom_corners(model, data, geoms: np.ndarray, unit: np.ndarray) -> np.ndarray:
    aabb = model.geom_aabb[geoms]  # (g, 6): centre and half sizes in the geom's frame
    local = aabb[:, None, :3] + unit[None] * aabb[:, None, 3:]  # (g, 8, 3)
    rotation = data.geom_xmat[geoms].reshape(-1, 3, 3)
    world = np.einsum("gij,gkj->gki", rotation, local) + data.geom_xpos[geoms][:, None, :]
    return world.reshape(-1, 3)


class FrameRenderer:
    """An offscreen GL context (given back for this thread's next render on ``close``) and a
    MuJoCo render context for one model and image size. It
    sets the model's offscreen size and quality and, but for ``high_quality``, draws its infinite
    floor finite (floor.py)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        backend: str,
        high_quality: bool = False,
    ):
        self._model = model
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        # the still geoms drawn once (backdrop.py); not with shadows or reflections, which
        # fall across what moves and what does not
        self._backdrop: Backdrop | None = None
        self._last_camera: CameraPose | None = None
        if not high_quality:
            model.vis.quality.offsamples = 0
            # shadows are off (below): no 4096² shadow map, 64 MB and ~0.04 s of CPU a context
            model.vis.quality.shadowsize = 1
            draw_infinite_planes_finite(model)  # half the frame's CPU otherwise: see floor.py
            self._backdrop = Backdrop(width, height)
        try:
            self._gl = take_context(backend, width, height)
        except Exception as error:  # the GL libraries raise their own types
            forget_remembered()  # a back-end remembered from an earlier run: tried afresh next time
            if isinstance(error, PreviewError):
                raise
            raise PreviewError(f"cannot create an offscreen {backend} context: {error}") from None
        font = (
            mujoco.mjtFontScale.mjFONTSCALE_100
            if height < 400
            else mujoco.mjtFontScale.mjFONTSCALE_150
        )
        try:
            self._context = mujoco.MjrContext(model, font)
        except mujoco.FatalError as error:  # e.g. a frame larger than the GL allows
            self._gl.free()
            raise PreviewError.naming(
                "width/height",
                f"cannot render {width}x{height} frames with {backend}: {error}; "
                "try a smaller {option}",
            ) from None
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        if not high_quality:
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
            self._scene.flags[mujoco.mjtRndFlag.mjRND_HAZE] = False
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._viewport = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.empty((height, width, 3), dtype=np.uint8)

    def render(
        self,
        data: mujoco.MjData,
        camera: CameraPose,
        status: tuple[str, str],
        problems: tuple[str, str],
    ) -> np.ndarray:
        self._gl.make_current()
        self._camera.lookat[:] = camera.lookat
        self._camera.distance = camera.distance
        self._camera.azimuth = camera.azimuth
        self._camera.elevation = camera.elevation
        still = camera == self._last_camera  # a camera that stays put: its backdrop pays off
        self._last_camera = camera

        def draw(categories: int, sky: bool) -> mujoco.MjvScene:
            mujoco.mjv_updateScene(
                self._model,
                data,
                self._option,
                self._perturb,
                self._camera,
                categories,
                self._scene,
            )
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = sky
            mujoco.mjr_render(self._viewport, self._scene, self._context)
            return self._scene

        laid = still and self._backdrop and self._backdrop.draw_over(draw, camera, self._context)
        if not laid:
            draw(mujoco.mjtCatBit.mjCAT_ALL, True)
        mujoco.mjr_overlay(
            mujoco.mjtFont.mjFONT_NORMAL,
            mujoco.mjtGridPos.mjGRID_TOPLEFT,
            self._viewport,
            *status,
            self._context,
        )
        if problems[0]:
            mujoco.mjr_overlay(
                mujoco.mjtFont.mjFONT_NORMAL,
                mujoco.mjtGridPos.mjGRID_BOTTOMLEFT,
                self._viewport,
                *problems,
                self._context,
            )
        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._context)
        return np.flipud(self._pixels).copy()

    def close(self) -> None:
        if self._context is not None:
            self._gl.make_current()
            if self._backdrop is not None:
                self._backdrop.free()
            self._context.free()
            self._context = None
            give_back(self._gl)  # for the next render: see gl.py

    def __enter__(self) -> FrameRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _write_mp4(
    path: Path, frames: Iterator[np.ndarray], fps: float, settings: RenderSettings
) -> None:
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path),
        (settings.width, settings.height),
        fps=fps,
        codec="libx264",
        pix_fmt_in="rgb24",
        pix_fmt_out="yuv420p",
        macro_block_size=1,
        quality=None,
        ffmpeg_log_level="error",
        output_params=["-preset", "veryfast", "-crf", "23"],
    )
    try:
        with _stop_signals_held():
            writer.send(None)  # starts ffmpeg
        for frame in frames:
            writer.send(np.ascontiguousarray(frame))
    finally:
        writer.close()


@contextlib.contextmanager
def _stop_signals_held() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP wait until the block ends, then arrive as usual.

    A stop that lands while imageio starts ffmpeg, after the process is running but before
    imageio's generator guards it, leaves ffmpeg running on its own: it writes the temporary
    video after it was removed (seen once in CI). Held, the stop arrives once ``writer.close``
    can end ffmpeg. Handlers, not a signal mask: ffmpeg would inherit a mask for its whole life.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread receives signals
        return
    held: list[int] = []
    signums = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    previous = {signum: signal.signal(signum, lambda n, _: held.append(n)) for signum in signums}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        if held:
            signal.raise_signal(held[0])


def _write_gif(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    from PIL import Image

    images = [Image.fromarray(frame).quantize(colors=256) for frame in frames]
    images[0].save(
        path, save_all=True, append_images=images[1:], loop=0, duration=round(1000 / fps)
    )


def _write_sheet(path: Path, frames: Iterator[np.ndarray], count: int) -> None:
    from PIL import Image

    tiles = list(frames)
    height, width, _ = tiles[0].shape
    columns = min(SHEET_COLUMNS, count)
    rows = math.ceil(count / columns)
    gap = 4
    sheet = np.full(
        (rows * height + (rows - 1) * gap, columns * width + (columns - 1) * gap, 3),
        255,
        dtype=np.uint8,
    )
    for k, tile in enumerate(tiles):
        row, column = divmod(k, columns)
        top, left = row * (height + gap), column * (width + gap)
        sheet[top : top + height, left : left + width] = tile
    Image.fromarray(sheet).save(path)
