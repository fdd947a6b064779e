"""The interactive viewer: where it cannot open a window, one line that says why and what to do
instead, worded for the library and for the command line."""

from __future__ import annotations

import pytest
from cli_helpers import PREVIEW_MOTIONS, error_line

from choreo.cli import main
from choreo.errors import PreviewError
from choreo.preview import (
    show_in_viewer,
    simulate,
)


def test_the_viewer_without_a_display_says_so(arm3, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    problem = "the viewer needs a display and neither DISPLAY nor WAYLAND_DISPLAY is set"
    with pytest.raises(PreviewError) as refused:  # the library names its own call
        show_in_viewer(simulate(arm3, [], [0, 0, 0]))
    assert str(refused.value) == f"{problem}; render to a file instead (render_preview)"
    assert main(["preview", str(PREVIEW_MOTIONS / "fine.yaml"), "--viewer"]) == 1
    assert error_line(capsys) == f"choreo: error: {problem}; render to a file instead (-o FILE)"


def test_the_viewer_on_a_display_that_is_not_there_is_one_line(monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["preview", str(PREVIEW_MOTIONS / "fine.yaml"), "--viewer"]) == 1
    line = error_line(capsys)  # GLFW's own reason in the brackets
    assert line.startswith("choreo: error: the viewer cannot open a window on display ':99' (")
    assert line.endswith("); render to a file instead (-o FILE)")
