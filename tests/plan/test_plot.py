"""choreo.plan.plot through `choreo plan --plot`: a time window of the plan, refused outside the
motion, never clamped."""

from __future__ import annotations

import pytest
from cli_helpers import WAVE, error_line, png_size
from paths import DATA

from choreo.cli import main
from choreo.errors import OptionError
from choreo.motion.motion_file import load_motion
from choreo.plan.pipeline import compile_motion
from choreo.plan.plot import plot_plan, plot_size_px

SIMPLE = DATA / "motions" / "simple.yaml"  # on the tiny robot: three joints, 2 s


def test_plan_plot_draws_a_time_window(tmp_path, capsys):
    # the tiny robot's three joints: a plot draws two charts a joint, most of a plot's CPU
    whole, window = tmp_path / "whole.png", tmp_path / "window.png"
    assert main(["plan", str(SIMPLE), "--plot", str(whole)]) == 0
    assert (
        main(["plan", str(SIMPLE), "--plot", str(window), "--plot-from", "0.5", "--plot-to", "1.5"])
        == 0
    )
    assert png_size(window) == png_size(whole) == plot_size_px(3)
    assert window.read_bytes() != whole.read_bytes()
    capsys.readouterr()


def test_a_window_draws_its_stretch_not_the_whole_motion(tmp_path):
    # the same title on both: the command's title names the window, which alone would differ
    motion = load_motion(SIMPLE)
    compiled = compile_motion(motion)
    drawn = {}
    for name, window_s in (("whole", None), ("window", (0.5, 1.5))):
        drawn[name] = tmp_path / f"{name}.png"
        plot_plan(
            compiled.trajectory,
            compiled.ticks,
            motion.robot,
            drawn[name],
            title="the same",
            window_s=window_s,
        )
    assert drawn["window"].read_bytes() != drawn["whole"].read_bytes()


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


@pytest.mark.parametrize("window_s", [(3.0, 2.0), (-1.0, 2.0), (0.0, 99.0)])
def test_the_library_refuses_a_window_outside_the_motion_by_its_name(tmp_path, window_s):
    motion = load_motion(WAVE)
    compiled = compile_motion(motion)
    with pytest.raises(OptionError) as refused:
        plot_plan(
            compiled.trajectory, compiled.ticks, motion.robot, tmp_path / "p.png", window_s=window_s
        )
    assert refused.value.option == "window_s" and "within 0..4.9 s" in str(refused.value)
    assert not (tmp_path / "p.png").exists()
