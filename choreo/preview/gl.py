"""Choosing the offscreen OpenGL back-end: EGL (Mesa) if it works, else OSMesa, unless
``MUJOCO_GL`` names one (GLFW too: an invisible window, so only with a display).

PyOpenGL fixes its platform at its first import, so a back-end that fails half-way cannot be
swapped for another in the same process: each candidate is tried in a subprocess first. The
renderer then creates its context from the chosen back-end's own class, so the choice holds even
when ``mujoco`` was imported earlier (by the robot loader) without ``MUJOCO_GL``.
``MUJOCO_GL=egl``, ``osmesa`` or ``glfw`` in the environment skips the trials; any other name is
refused when rendering, not before (the command line imports mujoco without it: see choreo.cli).

The trials cost some 0.5-0.85 s of CPU, so a back-end that worked is remembered in choreo's cache
(see choreo.robot.check_cache) under a digest of what the choice depends on: the Python and its
MuJoCo and PyOpenGL, the system's libraries (``/etc/ld.so.cache``, rewritten whenever a library
is installed or removed), its EGL vendors and GPU devices, and the environment variables that
steer EGL, Mesa and PyOpenGL. A failure is never remembered; a remembered back-end that fails to
render after all is forgotten (see :func:`forget_remembered`), so the next run tries again.

A GL context is kept for the thread's next render (:func:`take_context`, :func:`give_back`):
Mesa's software renderer compiles its shaders for each context anew, ~0.25 s of CPU a render.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import logging
import os
import re
import subprocess
import sys
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from choreo.errors import PreviewError
from choreo.robot import check_cache

log = logging.getLogger(__name__)

BACKENDS = ("egl", "osmesa")  # tried in this order when MUJOCO_GL names none
NAMED_BACKENDS = (*BACKENDS, "glfw")
# MUJOCO_GL values that name no back-end: unset, or mujoco's words for "no OpenGL at import"
UNNAMED = ("", "disable", "disabled", "off", "false", "0")
# Debian's names for Mesa's EGL and OSMesa with its software rasteriser
MESA_PACKAGES = ("libegl1", "libegl-mesa0", "libgl1", "libgles2", "libosmesa6", "libgl1-mesa-dri")
INSTALL_HINT = f"install Mesa's EGL and OSMesa, e.g. apt-get install {' '.join(MESA_PACKAGES)}"
TRIAL_TIMEOUT_S = 60
KEPT_CONTEXTS = 2  # a thread's GL contexts kept between renders (a few MB each)
REMEMBERED = "gl-backends"  # the cache's folder of back-ends that worked, by machine_key()
# What the trials' outcome depends on beyond the Python: the files and folders whose change may
# change it (by size, time and, for folders, their entries), and the environment's variables
# (not MUJOCO_GL nor PYOPENGL_PLATFORM: each trial sets its own, and rendering sets them after).
SYSTEM_PATHS = ("/etc/ld.so.cache", "/usr/share/glvnd/egl_vendor.d", "/dev/dri")
ENVIRONMENT_PREFIXES = ("EGL_", "__EGL_", "MESA_", "LIBGL_", "GALLIUM_")
ENVIRONMENT_NAMES = ("MUJOCO_EGL_DEVICE_ID", "LD_LIBRARY_PATH", "LD_PRELOAD")

_TRIAL = """
import importlib, sys
backend = sys.argv[1]
context = importlib.import_module("mujoco." + backend).GLContext(16, 16)
context.make_current()
import mujoco
model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100).free()
context.free()
"""


@functools.cache
def offscreen_backend() -> str:
    """The back-end to render with, chosen once per process (and exported as ``MUJOCO_GL``)."""
    chosen = choose_backend()
    os.environ.setdefault("MUJOCO_GL", chosen)
    log.info("offscreen rendering with %s", chosen)
    return chosen


def choose_backend() -> str:
    """MUJOCO_GL if it names a back-end, else the first that works: EGL, then OSMesa."""
    given = os.environ.get("MUJOCO_GL", "")
    requested = given.strip().lower()
    if requested in NAMED_BACKENDS:
        return requested
    if requested not in UNNAMED:
        raise PreviewError(
            f"MUJOCO_GL={given} is not an OpenGL back-end to render with: set it to "
            f"{', '.join(NAMED_BACKENDS[:-1])} or {NAMED_BACKENDS[-1]}, or unset it to use "
            "the first that works"
        )
    if "OpenGL" in sys.modules:  # PyOpenGL's platform is already fixed in this process
        platform = os.environ.get("PYOPENGL_PLATFORM", "").lower()
        if platform in BACKENDS:
            return platform
    key = machine_key()
    remembered = check_cache.recall(REMEMBERED, key)
    if remembered in BACKENDS:
        return remembered
    failures = []
    for backend in BACKENDS:
        problem = backend_problem(backend)
        if problem is None:
            check_cache.keep(REMEMBERED, key, backend)
            return backend
        failures.append(f"{backend}: {problem}")
    raise PreviewError(
        f"cannot render offscreen: no OpenGL back-end works ({'; '.join(failures)}); {INSTALL_HINT}"
    )


def machine_key() -> str:
    """The digest a back-end that worked is remembered under: what the trials depend on."""
    digest = hashlib.sha256(f"1\0{sys.executable}\0{sys.version}\0".encode())
    if hasattr(os, "getgroups"):  # the GPU's device files are often for a group's members only
        digest.update(f"{os.getuid()}\0{sorted(os.getgroups())}\0".encode())
    for module in ("mujoco", "OpenGL"):
        spec = importlib.util.find_spec(module)  # found, not imported
        digest.update(_identity(Path(spec.origin)) if spec and spec.origin else b"absent\0")
    for path in SYSTEM_PATHS:
        digest.update(_identity(Path(path)))
    for name in sorted(os.environ):
        if name.startswith(ENVIRONMENT_PREFIXES) or name in ENVIRONMENT_NAMES:
            digest.update(f"{name}={os.environ[name]}\0".encode())
    return digest.hexdigest()


def _identity(path: Path) -> bytes:
    """A file's path, size and time of change; a folder's also lists its entries."""
    try:
        stat = path.stat()
        entries = sorted(os.listdir(path)) if path.is_dir() else []
    except OSError:
        return f"{path}\0absent\0".encode()
    return f"{path}\0{stat.st_size}\0{stat.st_mtime_ns}\0{entries}\0".encode()


def forget_remembered() -> None:
    """Forget the back-end remembered for this machine (one that failed to render after all)."""
    check_cache.forget(REMEMBERED, machine_key())


def backend_problem(backend: str) -> str | None:
    """Why ``backend`` cannot create a GL context and a MuJoCo render context (tried in a
    subprocess), or None if it can."""
    env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
    try:
        done = subprocess.run(
            [sys.executable, "-c", _TRIAL, backend],
            env=env,
            capture_output=True,
            text=True,
            timeout=TRIAL_TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return f"no answer within {TRIAL_TIMEOUT_S} s"
    if done.returncode == 0:
        return None
    lines = done.stderr.strip().splitlines()
    return lines[-1] if lines else f"exit status {done.returncode}"


def context_class(backend: str):
    """The GL context class of ``backend`` (imports PyOpenGL for that platform)."""
    if backend not in NAMED_BACKENDS:
        raise ValueError(
            f"unknown offscreen back-end {backend!r}; valid: {', '.join(NAMED_BACKENDS)}"
        )
    if backend == "glfw":
        problem = window_system_problem()
        if problem is not None:
            raise PreviewError(
                f"cannot render with glfw: {problem}; unset MUJOCO_GL to render with "
                f"{' or '.join(BACKENDS)}"
            )
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        elif backend == "osmesa":
            from mujoco.osmesa import GLContext
        else:
            from mujoco.glfw import GLContext
    except (ImportError, OSError, AttributeError) as error:
        raise PreviewError(
            f"cannot render offscreen with {backend}: {error}; {INSTALL_HINT}"
        ) from None
    return GLContext


def window_system_problem() -> str | None:
    """Why GLFW cannot reach the display (e.g. a stale DISPLAY over SSH), or None if it can."""
    import glfw

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if glfw.init():
            return None
    # GLFW's warnings read "(65550) b'X11: Failed to open display :99'"
    reasons = [re.sub(r"^\(\d+\) b?'(.*)'$", r"\1", str(w.message)) for w in caught]
    return "; ".join(reasons) or "GLFW could not start"


@dataclass(frozen=True)
class OffscreenContext:
    """A GL context of ``backend`` for frames up to ``width`` x ``height``."""

    backend: str
    width: int
    height: int
    context: Any  # the back-end's GLContext (mujoco.egl, mujoco.osmesa or mujoco.glfw)

    def make_current(self) -> None:
        self.context.make_current()

    def free(self) -> None:
        self.context.free()


_kept = threading.local()  # .contexts: this thread's, given back, oldest first


def take_context(backend: str, width: int, height: int) -> OffscreenContext:
    """A GL context of ``backend`` for frames up to ``width`` x ``height``: one this thread gave
    back after an earlier render (a context is current in one thread at a time, so each
    thread keeps its own), else a new one. Current in this thread."""
    kept = _kept_here()
    for k, offscreen in enumerate(kept):
        fits = offscreen.width >= width and offscreen.height >= height
        if offscreen.backend == backend and fits:
            del kept[k]
            break
    else:
        offscreen = OffscreenContext(backend, width, height, context_class(backend)(width, height))
    offscreen.make_current()
    return offscreen


def give_back(offscreen: OffscreenContext) -> None:
    """Keep ``offscreen`` (its MuJoCo render context freed) for this thread's next render; the
    oldest beyond ``KEPT_CONTEXTS`` is freed."""
    kept = _kept_here()
    kept.append(offscreen)
    while len(kept) > KEPT_CONTEXTS:
        kept.pop(0).free()


def _kept_here() -> list[OffscreenContext]:
    if not hasattr(_kept, "contexts"):
        _kept.contexts = []
    return _kept.contexts
