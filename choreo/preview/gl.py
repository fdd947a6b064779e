"""Choosing the offscreen OpenGL back-end: EGL (Mesa) if it works, else OSMesa.

PyOpenGL fixes its platform at its first import, so a back-end that fails half-way cannot be
swapped for another in the same process: each candidate is tried in a subprocess first. The
renderer then creates its context from the chosen back-end's own class, so the choice holds even
when ``mujoco`` was imported earlier (by the robot loader) without ``MUJOCO_GL``.
``MUJOCO_GL=egl`` or ``osmesa`` in the environment skips the probe.
"""

from __future__ import annotations

import functools
import logging
import os
import subprocess
import sys

from choreo.errors import PreviewError

log = logging.getLogger(__name__)

BACKENDS = ("egl", "osmesa")
# Debian's names for Mesa's EGL and OSMesa with its software rasteriser
MESA_PACKAGES = ("libegl1", "libegl-mesa0", "libgl1", "libgles2", "libosmesa6", "libgl1-mesa-dri")
INSTALL_HINT = f"install Mesa's EGL and OSMesa, e.g. apt-get install {' '.join(MESA_PACKAGES)}"
PROBE_TIMEOUT_S = 60

_PROBE = """
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
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    if requested in BACKENDS:
        return requested
    if "OpenGL" in sys.modules:  # PyOpenGL's platform is already fixed in this process
        platform = os.environ.get("PYOPENGL_PLATFORM", "").lower()
        if platform in BACKENDS:
            return platform
    failures = []
    for backend in BACKENDS:
        problem = probe(backend)
        if problem is None:
            return backend
        failures.append(f"{backend}: {problem}")
    raise PreviewError(
        f"cannot render offscreen: no OpenGL back-end works ({'; '.join(failures)}); {INSTALL_HINT}"
    )


def probe(backend: str) -> str | None:
    """None if ``backend`` can create a context and a MuJoCo render context, else why not."""
    env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE, backend],
            env=env,
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return f"no answer within {PROBE_TIMEOUT_S} s"
    if done.returncode == 0:
        return None
    lines = done.stderr.strip().splitlines()
    return lines[-1] if lines else f"exit status {done.returncode}"


def context_class(backend: str):
    """The GL context class of ``backend`` (imports PyOpenGL for that platform)."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown offscreen back-end {backend!r}; valid: {', '.join(BACKENDS)}")
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
    except (ImportError, OSError, AttributeError) as error:
        raise PreviewError(
            f"cannot render offscreen with {backend}: {error}; {INSTALL_HINT}"
        ) from None
    return GLContext
