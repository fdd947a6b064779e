"""The report of a planned and compiled motion: its length, ticks and bytes, each joint's peaks
against its limits, the keyframes as the planner got them; what ``choreo plan`` prints and
``choreo plan --json`` writes."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from choreo.core.arguments import check_flag, check_number, check_type
from choreo.errors import OptionError
from choreo.motion.motion_file import Motion
from choreo.motion.music_block import Music
from choreo.motion.timing import SPEED
from choreo.plan.pipeline import CompiledMotion


@dataclass(frozen=True)
class JointFigures:
    name: str
    peak_velocity_deg_s: float
    velocity_limit_deg_s: float
    peak_acceleration_deg_s2: float
    acceleration_limit_deg_s2: float
    staged_moves: int


def plan_report(
    motion: Motion, compiled: CompiledMotion, speed: float, *, keyframes: bool = True
) -> dict[str, Any]:
    """The figures of a compiled motion (``choreo plan`` prints them, ``--json`` as they are),
    as plain JSON-ready values; ``speed``: the one it was compiled at. Without ``keyframes``
    the expanded keyframes (some 0.03 s for 2,000 keyframes) are left out: None."""
    check_type("motion", motion, Motion, "a Motion (from load_motion)")
    check_type("compiled", compiled, CompiledMotion, "a CompiledMotion (from compile_motion)")
    if compiled.robot.joint_names != motion.robot.joint_names:
        raise OptionError(
            "compiled",
            f"is a motion of {compiled.robot.name}, not of {motion.robot.name}: compile this "
            "motion (compile_motion)",
        )
    check_number("speed", speed, SPEED)
    check_flag("keyframes", keyframes)
    trajectory, ticks = compiled.trajectory, compiled.ticks
    peak_vel = trajectory.peak_velocity_deg_s()
    peak_acc = trajectory.peak_acceleration_deg_s2()
    # each joint's staged moves, counted column by column: an array of the 70,000 flags of a
    # 2,000-keyframe motion took numpy 10 million instructions more to read
    staged_moves = [sum(column) for column in zip(*(t.staged for t in ticks.ticks))]
    joints = [
        JointFigures(
            joint.name,
            float(peak_vel[j]),
            joint.limits.vel_deg_s,
            float(peak_acc[j]),
            joint.limits.acc_deg_s2,
            moves,
        )
        for j, (joint, moves) in enumerate(
            zip(motion.robot.joints, staged_moves or [0] * len(peak_vel))
        )
    ]
    return {
        "motion": str(motion.path),
        "robot": motion.robot.name,
        "speed": speed,
        "duration_s": trajectory.duration_s,
        "keyframes": len(trajectory.keyframe_times_s),
        "keyframe_times_s": [float(t) for t in trajectory.keyframe_times_s],
        "music": music_report(motion.music) if motion.music else None,
        "ticks": len(ticks.ticks),
        "bytes": ticks.total_bytes,
        "peak_bus_use": ticks.peak_bus_use,
        "tolerance_deg": ticks.tolerance_deg,
        "max_deviation_deg": ticks.max_deviation_deg,
        "stretches": [{"where": str(s.where), "shift_s": s.shift_s} for s in compiled.stretches],
        "joints": [vars(j) for j in joints],
        "expanded_keyframes": expanded_keyframes(motion) if keyframes else None,
    }


def expanded_keyframes(motion: Motion) -> list[dict[str, Any]]:
    """Every keyframe as the planner gets it (includes, gaits and IK expanded): joint angles."""
    names = motion.robot.joint_names
    return [
        {
            "where": str(k.where),
            **({"label": k.label} if k.label else {}),
            **({"t_s": k.t_s} if k.t_s is not None else {}),
            **({"after_s": k.after_s} if k.after_s is not None else {}),
            **({"hold_s": k.hold_s} if k.hold_s else {}),
            "stop": k.stop,
            "targets_deg": {name: round(a, 3) for name, a in zip(names, k.targets_deg)},
        }
        for k in motion.keyframes
    ]


def music_report(music: Music) -> dict[str, Any]:
    return {
        "song": str(music.song),
        "start_s": music.start_s,
        "bpm": music.bpm,
        "beats_per_bar": music.grid.beats_per_bar,
        "beat_times_s": list(music.grid.beat_times_s),  # motion time of beat 1, 2, ...
        "bar_one_beat": music.grid.bar_one_beat,
        "note": music.note,
    }
