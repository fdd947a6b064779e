"""A picture of a plan: per joint, position and velocity over time, the smooth trajectory
against what the servos will do (straight moves between tick targets).

Drawn with matplotlib's Agg canvas directly (no pyplot, no display, no global backend state).
The image size depends only on the number of joints: see ``plot_size_px``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from choreo.core.atomic import atomic_output
from choreo.errors import OptionError
from choreo.plan.ticks import TickPlan
from choreo.plan.trajectory import Trajectory
from choreo.robot.types import Robot

DPI = 100
WIDTH_PX = 1400
TOP_PX = 80  # title, legend and the column titles
BOTTOM_PX = 45  # the time axis
ROW_PX = 130  # one joint
SMOOTH_COLOR = "#1f77b4"
TICK_COLOR = "#d62728"
KEYFRAME_COLOR = "#999999"
MIN_SPAN_DEG = 10.0  # a joint that hardly moves is drawn flat, not magnified


def plot_size_px(n_joints: int) -> tuple[int, int]:
    """(width, height) in pixels of the PNG ``plot_plan`` writes for ``n_joints`` joints."""
    return WIDTH_PX, TOP_PX + BOTTOM_PX + ROW_PX * n_joints


def plot_plan(
    trajectory: Trajectory,
    plan: TickPlan,
    robot: Robot,
    path: Path,
    title: str = "",
    window_s: tuple[float, float] | None = None,
) -> None:
    """Write a PNG: one row per joint, position (left) and velocity (right) against time;
    ``window_s`` = (start, end) draws only that stretch of a long motion, in full detail."""
    # matplotlib (a second to import) only when a picture is drawn: a module that only reads
    # the picture's size in pixels does without it
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = len(robot.joints)
    width, height = plot_size_px(n)
    figure = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    FigureCanvasAgg(figure)
    axes = figure.subplots(n, 2, sharex=True, squeeze=False)
    figure.subplots_adjust(
        left=0.09,
        right=0.985,
        top=1 - TOP_PX / height,
        bottom=BOTTOM_PX / height,
        hspace=0.12,
        wspace=0.16,
    )
    start_s, end_s = _window(trajectory, window_s)
    times_s = np.linspace(start_s, end_s, int(np.clip((end_s - start_s) * 400, 2000, 40000)))
    pos, vel, _ = trajectory.sample(times_s)
    bounds_s, tick_deg, tick_vel = _servo_path(trajectory, plan, robot)
    # the ticks in the window and one either side: the y axes fit what is shown
    first = max(int(np.searchsorted(bounds_s, start_s, side="right")) - 1, 0)
    last = min(int(np.searchsorted(bounds_s, end_s, side="left")) + 1, len(bounds_s))
    bounds_s, tick_deg, tick_vel = (
        bounds_s[first:last],
        tick_deg[first:last],
        tick_vel[first : max(last - 1, first)],
    )
    for j, joint in enumerate(robot.joints):
        ax_pos, ax_vel = axes[j]
        for ax in (ax_pos, ax_vel):
            _keyframe_lines(ax, trajectory.keyframe_times_s)
        _draw_position(ax_pos, joint.name, times_s, pos[:, j], bounds_s, tick_deg[:, j])
        tick_vel_j = tick_vel[:, j] if len(tick_vel) else None
        _draw_velocity(ax_vel, joint.limits.vel_deg_s, times_s, vel[:, j], bounds_s, tick_vel_j)
    axes[0, 0].set_xlim(start_s, end_s)  # shared by every row
    _label(figure, axes, height, title or _default_title(trajectory, plan))
    with atomic_output(path) as temporary:
        figure.savefig(temporary, format="png", dpi=DPI)


def _window(trajectory: Trajectory, window_s: tuple[float, float] | None) -> tuple[float, float]:
    """The stretch drawn: ``window_s``, checked to lie within the motion, or all of it."""
    if window_s is None:
        return 0.0, max(trajectory.duration_s, 1e-3)
    start_s, end_s = window_s
    if not 0 <= start_s < end_s <= trajectory.duration_s + 1e-9:
        raise OptionError(
            "window_s",
            f"must lie within 0..{trajectory.duration_s:g} s with start < end, got {window_s}",
        )
    return start_s, max(end_s, start_s + 1e-3)


def _keyframe_lines(ax, keyframe_times_s) -> None:
    ax.vlines(
        keyframe_times_s,
        0,
        1,
        transform=ax.get_xaxis_transform(),
        color=KEYFRAME_COLOR,
        linewidth=0.6,
        alpha=0.6,
        label="keyframe",
    )
    ax.tick_params(labelsize=8)
    ax.grid(True, linewidth=0.3, alpha=0.5)


def _draw_position(ax, name: str, times_s, pos_deg, bounds_s, tick_deg) -> None:
    ax.plot(times_s, pos_deg, color=SMOOTH_COLOR, linewidth=3.0, alpha=0.45, label="smooth plan")
    ax.plot(
        bounds_s,
        tick_deg,
        color=TICK_COLOR,
        linewidth=0.9,
        marker="o",
        markersize=2.2,
        label="servo ticks",
    )
    _pad_flat_axis(ax, pos_deg, MIN_SPAN_DEG)
    ax.set_ylabel(f"{name}\n°", fontsize=9)


def _draw_velocity(ax, limit_deg_s: float, times_s, vel_deg_s, bounds_s, tick_vel) -> None:
    ax.plot(times_s, vel_deg_s, color=SMOOTH_COLOR, linewidth=3.0, alpha=0.45)
    if tick_vel is not None:
        ax.stairs(tick_vel, bounds_s, color=TICK_COLOR, linewidth=0.9, baseline=None)
    for sign in (-1, 1):
        ax.axhline(sign * limit_deg_s, color="black", linewidth=0.7, linestyle="--")
    ax.set_ylim(-1.08 * limit_deg_s, 1.08 * limit_deg_s)
    ax.set_ylabel("°/s", fontsize=9)


def _label(figure, axes, height_px: int, title: str) -> None:
    """Column titles, the time axis, one legend for every row, and the title."""
    axes[0, 0].set_title("position", fontsize=10)
    axes[0, 1].set_title("velocity (dashed: ±limit)", fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)", fontsize=9)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    figure.legend(
        handles,
        labels,
        loc="upper right",
        bbox_to_anchor=(0.985, 1 - 6 / height_px),
        ncol=3,
        fontsize=9,
        frameon=False,
    )
    figure.suptitle(title, x=0.09, y=1 - 12 / height_px, ha="left", va="top", fontsize=11)


def _pad_flat_axis(ax, values, min_span: float) -> None:
    low, high = float(values.min()), float(values.max())
    if high - low < min_span:
        middle = (low + high) / 2
        ax.set_ylim(middle - min_span / 2, middle + min_span / 2)


def _servo_path(
    trajectory: Trajectory, plan: TickPlan, robot: Robot
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tick boundaries (s), the servos' positions there (degrees of the rounded targets, from
    the rounded start) and each tick's constant velocity."""
    start = trajectory.at(0.0)[0]
    units = np.array([np.rint(robot.to_units(start)), *(t.targets_units for t in plan.ticks)])
    tick_deg = robot.to_deg(units)
    bounds_s = np.array([0.0] + [t.end_ms / 1000 for t in plan.ticks])
    durations_s = np.diff(bounds_s)[:, None]
    tick_vel = (
        np.diff(tick_deg, axis=0) / durations_s
        if len(durations_s)
        else np.empty((0, len(robot.joints)))
    )
    return bounds_s, tick_deg, tick_vel


def _default_title(trajectory: Trajectory, plan: TickPlan) -> str:
    return (
        f"{trajectory.duration_s:.2f} s, {len(plan.ticks)} ticks, {plan.total_bytes} bytes, "
        f"max deviation {plan.max_deviation_deg:.2f}° (tolerance {plan.tolerance_deg:g}° "
        f"+ rounding)"
    )
