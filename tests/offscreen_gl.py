"""Offscreen OpenGL for the tests that render, found or installed once per run.

The preview renders with Mesa's EGL or OSMesa. A fresh machine may have neither: as root with
apt-get, the run installs Debian's Mesa packages (the ones choreo's own hint names); elsewhere it
stops with choreo's line that names what to install.
"""

from __future__ import annotations

from collections.abc import Callable

from apt_packages import apt_get_install

from choreo.errors import PreviewError
from choreo.preview import gl


class NoOffscreenGL(Exception):
    """No offscreen OpenGL works here; the message says what to install."""


def provide(say: Callable[[str], None]) -> str:
    """The back-end that works (``egl`` or ``osmesa``), after installing Mesa if it must."""
    try:
        return gl.choose_backend()
    except PreviewError as missing:
        what = "Mesa's EGL and OSMesa for the tests that render"
        if not apt_get_install(gl.MESA_PACKAGES, what, say):
            raise NoOffscreenGL(str(missing)) from None
        try:
            return gl.choose_backend()
        except PreviewError as still:
            raise NoOffscreenGL(str(still)) from None
