"""choreo.plan.plot through `choreo plan --plot`: a time window of the plan, refused outside the
motion, never clamped."""

from __future__ import annotations

import pytest
from cli_helpers import WAVE, error_line, png_size

from choreo.cli import main
from choreo.plan.plot import plot_size_px


def test_plan_plot_draws_a_time_window(tmp_path, capsys):
    whole, window = tmp_path / "whole.png", tmp_path / "window.png"
    assert main(["plan", str(WAVE), "--plot", str(whole)]) == 0
    assert (
        main(["plan", str(WAVE), "--plot", str(window), "--plot-from", "2", "--plot-to", "4"]) == 0
    )
    assert png_size(window) == png_size(whole) == plot_size_px(6)
    assert window.read_bytes() != whole.read_bytes()
    capsys.readouterr()


@pytest.mark.parametrize(
    "extra, line",
    [
        (
            ["--plot-from", "20"],
            "choreo: error: --plot-from 20 is past the end of the motion: it lasts 4.900 s",
        ),
        (
            ["--plot-to", "9"],
            "choreo: error: --plot-to 9 is past the end of the motion: it lasts 4.900 s",
        ),
        (
            ["--plot-from", "3", "--plot-to", "2"],
            "choreo: error: --plot-from 3 must be before --plot-to 2",
        ),
    ],
)
def test_a_plot_window_outside_the_motion_is_refused_not_clamped(tmp_path, capsys, extra, line):
    plot = tmp_path / "p.png"
    assert main(["plan", str(WAVE), "--plot", str(plot), *extra]) == 2
    assert capsys.readouterr().err == line + "\n"
    assert not plot.exists()


def test_a_plot_window_needs_a_plot(capsys):
    assert main(["plan", str(WAVE), "--plot-from", "1"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --plot-from and --plot-to choose what --plot draws: add --plot FILE.png"
    )
