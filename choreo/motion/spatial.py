"""Keyframes written in space — ``sites:``, ``body:`` and ``gait:`` — read and expanded into
ordinary joint keyframes by inverse kinematics when the motion loads.

    - sites: {tool: {at: [160, 0, 40], pitch: -80}}   # the tool there, pointing 80° down
      pose: {gripper: 40}                                # joints given alongside stay fixed
    - body: {z: 20, roll: 5}                             # feet planted, body up and tilted
    - gait: {pattern: tripod, steps: 6, stride: 40}      # a walk, ending standing

Each IK is seeded from the keyframe before it and stays inside the joint limits; an
unreachable target is reported at its line with the closest point the site can reach.
The planner, the tick compiler and the player only ever see the joint keyframes that come out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np
import yaml

from choreo.core.yaml_source import Entry, Node, Problems, Reader, SourceLocation, did_you_mean, fmt
from choreo.motion.gait import SIX_LEGS, BodyPose, Gait, Pattern, feet_under_body, gait_keyframes
from choreo.motion.timing import MAX_TIME_S
from choreo.robot.poses import HOME_POSE
from choreo.robot.types import GaitCompensation, Robot

if TYPE_CHECKING:
    from choreo.robot.kinematics import Kinematics, SiteGoal, Solution

FRAMES = ("base", "world")
SITE_KEYS = ("at", "pitch", "frame")
BODY_KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
GAIT_KEYS = ("pattern", "steps", "stride", "sideways", "turn", "lift", "period")


@dataclass(frozen=True)
class SiteTarget:
    site: str
    at_mm: tuple[float, float, float]
    frame: str  # "base" or "world"
    pitch_deg: float | None
    where: SourceLocation


@dataclass(frozen=True)
class SitesSpec:
    targets: tuple[SiteTarget, ...]


@dataclass(frozen=True)
class BodySpec:
    pose: BodyPose


@dataclass(frozen=True)
class GaitSpec:
    gait: Gait
    steps_at: SourceLocation  # where its steps were written


@dataclass(frozen=True)
class GaitEnd:
    """Marks the last keyframe of a ``gait:`` block: the gait and its number of keyframes (the
    preview compares the walk it asked for with the walk it got)."""

    gait: Gait
    keyframes: int
    where: SourceLocation  # the gait: line


Spatial = SitesSpec | BodySpec | GaitSpec


# --- reading ------------------------------------------------------------------------------------

# Lengths within 10 m and angles within a turn: past any desktop or walking robot's reach, and
# far from the numbers (1e300) that overflow the solver and fill a message with 300 digits.
MM: dict[str, Any] = {"low": -10_000, "high": 10_000}
DEGREES: dict[str, Any] = {"low": -180, "high": 180}


def read_sites(reader: Reader, node: Node) -> SitesSpec | None:
    """``sites: {name: {at: [x, y, z], pitch: deg, frame: base|world}}`` (mm, degrees)."""
    entries = reader.entries(node, "sites")
    if entries is None:
        return None
    if not entries:
        reader.report(node, "sites: give at least one site, e.g. {tool: {at: [150, 0, 50]}}")
        return None
    targets = [_read_site(reader, entry) for entry in entries]
    if None in targets:
        return None
    return SitesSpec(tuple(t for t in targets if t is not None))


def _read_site(reader: Reader, entry: Entry) -> SiteTarget | None:
    what = f"sites: {entry.key}"
    fields = reader.fields(entry.value, what, SITE_KEYS, required=("at",))
    if fields is None or "at" not in fields:
        return None
    at = _read_point(reader, fields["at"].value, f"{what}: at")
    pitch = (
        reader.number(fields["pitch"].value, f"{what}: pitch", low=-90, high=90)
        if "pitch" in fields
        else None
    )
    frame = (
        reader.choice(fields["frame"].value, f"{what}: frame", FRAMES)
        if "frame" in fields
        else "base"
    )
    if at is None or frame is None or ("pitch" in fields and pitch is None):
        return None
    return SiteTarget(entry.key, at, frame, pitch, reader.where(entry.key_node))


def _read_point(reader: Reader, node: Node, what: str) -> tuple[float, float, float] | None:
    items = reader.sequence(node, what)
    if items is None:
        return None
    if len(items) != 3:
        reader.report(node, f"{what} must be [x, y, z] in mm, got {len(items)} numbers")
        return None
    numbers = [reader.number(item, what, **MM) for item in items]
    if None in numbers:
        return None
    x, y, z = (float(n) for n in numbers if n is not None)
    return x, y, z


def read_body(reader: Reader, node: Node) -> BodySpec | None:
    """``body: {x, y, z (mm), roll, pitch, yaw (degrees)}``, any of them."""
    fields = reader.fields(node, "body", BODY_KEYS)
    if fields is None:
        return None
    values = {
        key: reader.number(entry.value, f"body: {key}", **(MM if key in "xyz" else DEGREES))
        for key, entry in fields.items()
    }
    if None in values.values():
        return None
    names = {"x": "x_mm", "y": "y_mm", "z": "z_mm"}
    kwargs: dict[str, Any] = {names.get(k, f"{k}_deg"): v for k, v in values.items()}
    return BodySpec(BodyPose(**kwargs))


def read_gait(reader: Reader, node: Node) -> GaitSpec | None:
    """``gait: {pattern, steps, stride, sideways (mm), turn (deg), lift (mm), period (s)}``."""
    fields = reader.fields(node, "gait", GAIT_KEYS, required=("steps",))
    if fields is None or "steps" not in fields:
        return None
    patterns = [p.value for p in Pattern]
    pattern = (
        reader.choice(fields["pattern"].value, "gait: pattern", patterns)
        if "pattern" in fields
        else Pattern.TRIPOD.value
    )
    steps = reader.integer(fields["steps"].value, "gait: steps", low=1)
    bounds: dict[str, dict[str, Any]] = {
        "stride": MM,
        "sideways": MM,
        "turn": {"low": -45, "high": 45},
        "lift": {"low": 0, "high": MM["high"]},
        "period": {"low": 0, "low_open": True, "high": MAX_TIME_S, "unit": " s"},
    }
    numbers = {
        key: reader.number(fields[key].value, f"gait: {key}", **limits)
        for key, limits in bounds.items()
        if key in fields
    }
    if pattern is None or steps is None or None in numbers.values():
        return None
    names = {"stride": "stride_mm", "sideways": "sideways_mm", "turn": "turn_deg"}
    names.update(lift="lift_mm", period="period_s")
    kwargs: dict[str, Any] = {names[k]: v for k, v in numbers.items()}
    return GaitSpec(Gait(Pattern(pattern), steps, **kwargs), reader.where(fields["steps"].value))


# --- expanding ----------------------------------------------------------------------------------


class _Step(Protocol):
    @property
    def angles_deg(self) -> Any: ...
    @property
    def where(self) -> SourceLocation: ...
    @property
    def space(self) -> Spatial | None: ...


StepT = TypeVar("StepT", bound=_Step)


def expand_spatial(robot: Robot, steps: Sequence[StepT], problems: Problems) -> list[StepT]:
    """The steps with every ``sites:``/``body:`` keyframe solved into joint angles and every
    ``gait:`` block replaced by its keyframes; problems are reported at their lines."""
    if not any(step.space is not None for step in steps):
        return list(steps)
    expander = _Expander(robot, problems)
    out: list[StepT] = []
    for step in steps:
        out.extend(expander.expand(step))
    return out


class _Expander:
    def __init__(self, robot: Robot, problems: Problems) -> None:
        from choreo.robot.kinematics import (
            Kinematics,  # loads MuJoCo: only for motions that need it
        )

        self.robot = robot
        self.problems = problems
        self.kin: Kinematics = Kinematics(robot)
        self.current = np.array(robot.pose_vector(HOME_POSE), dtype=float)
        self.stance = self.current.copy()  # where the feet were last planted (for body:)
        self.failed = False

    def expand(self, step: StepT) -> list[StepT]:
        names = self.robot.joint_names
        fixed = np.array([name in step.angles_deg for name in names])
        for j, name in enumerate(names):
            if name in step.angles_deg:
                self.current[j] = step.angles_deg[name]
        space = step.space
        if space is None or self.failed:  # after a failure the seeds mean nothing: say it once
            if space is None:
                self.stance = self.current.copy()
            return [step]
        if isinstance(space, GaitSpec):
            return self._gait(step, space.gait, fixed)
        solved = (
            self._sites(step, space, fixed)
            if isinstance(space, SitesSpec)
            else self._body(step, space.pose, fixed)
        )
        if solved is None:
            return [step]
        if isinstance(space, SitesSpec):
            self.stance = solved.copy()
            return [self._joint_step(step, solved, sites=space.targets)]
        return [self._joint_step(step, solved, body=space.pose)]

    def _joint_step(self, step: StepT, angles_deg: np.ndarray, **changes: Any) -> StepT:
        self.current = angles_deg.copy()
        angles = {name: round(float(a), 3) for name, a in zip(self.robot.joint_names, angles_deg)}
        return replace(step, angles_deg=angles, space=None, label="", **changes)  # type: ignore[type-var]

    def _fail(self, where: SourceLocation, message: str) -> None:
        self.problems.add(where, message)
        self.failed = True

    # sites: ---------------------------------------------------------------------------------

    def _sites(self, step: _Step, spec: SitesSpec, fixed: np.ndarray) -> np.ndarray | None:
        from choreo.robot.kinematics import SiteGoal

        goals = []
        for target in spec.targets:
            if self.kin.site_id(target.site) < 0:
                sites = self.kin.site_names
                self._fail(
                    target.where,
                    f"robot {self.robot.name!r} has no site {target.site!r}"
                    f"{did_you_mean(target.site, sites)}; its sites: "
                    f"{', '.join(sites) or 'none (add <site> elements to its MJCF)'}",
                )
                return None
            at = target.at_mm if target.frame == "base" else self.kin.world_to_base_mm(target.at_mm)
            goals.append(SiteGoal(target.site, _xyz(at), target.pitch_deg))
        solution = self.kin.solve(goals, self.current, ~fixed)
        if not solution.ok:
            self._unreachable(spec.targets, goals, solution, fixed)
            return None
        return solution.angles_deg

    def _unreachable(
        self,
        targets: Sequence[SiteTarget],
        goals: Sequence[SiteGoal],
        solution: Solution,
        fixed: np.ndarray,
    ) -> None:
        held = [n for n, f in zip(self.robot.joint_names, fixed) if f]
        for target, goal, reached, distance, pitch_error in zip(
            targets, goals, solution.reached, solution.position_error_mm, solution.pitch_error_deg
        ):
            if distance <= 0.5 and pitch_error <= 0.5:
                continue
            pitch = (
                f", pitch {fmt(round(goal.pitch_deg, 1))}°" if goal.pitch_deg is not None else ""
            )
            got_pitch = f", pitch {reached.pitch_deg:.1f}°" if goal.pitch_deg is not None else ""
            off = f" and {pitch_error:.1f}° off" if pitch_error > 0.5 else ""
            held_text = f" with {', '.join(held)} held as given" if held else ""
            self._fail(
                target.where,
                f"site {target.site!r} cannot reach {_point(goal.position_mm)} mm (base frame)"
                f"{pitch}: the closest it gets is {_point(reached.position_mm)} mm{got_pitch}, "
                f"{distance:.1f} mm away{off}, inside the joint limits{held_text}; "
                f"choose a target within reach",
            )

    # body: and gait: ------------------------------------------------------------------------

    def _feet(self, where: SourceLocation, what: str) -> tuple[str, ...] | None:
        feet = self.kin.feet()
        if not feet:
            self._fail(
                where,
                f"{what} needs the robot's feet: robot {self.robot.name!r} lists none (add "
                f'<custom><text name="choreo:feet" data="foot_site ..."/></custom> to its MJCF)',
            )
            return None
        return feet

    def _feet_mm(self, feet: Sequence[str], angles_deg: np.ndarray) -> np.ndarray:
        return self.kin.site_positions_mm(feet, angles_deg)

    def _solve_feet(
        self,
        feet: Sequence[str],
        feet_mm: np.ndarray,
        fixed: np.ndarray,
        where: SourceLocation,
        what: str,
    ) -> np.ndarray | None:
        from choreo.robot.kinematics import SiteGoal

        goals = [SiteGoal(foot, _xyz(p)) for foot, p in zip(feet, feet_mm)]
        solution = self.kin.solve(goals, self.current, ~fixed)
        if solution.ok:
            return solution.angles_deg
        worst = int(np.argmax(solution.position_error_mm))
        self._fail(
            where,
            f"{what}: foot {feet[worst]!r} cannot reach {_point(feet_mm[worst])} mm (body "
            f"frame): the closest it gets is {_point(solution.reached[worst].position_mm)} mm, "
            f"{solution.position_error_mm[worst]:.1f} mm away, inside the joint limits; "
            f"ask for a smaller move",
        )
        return None

    def _body(self, step: _Step, pose: BodyPose, fixed: np.ndarray) -> np.ndarray | None:
        feet = self._feet(step.where, "body:")
        if feet is None:
            return None
        feet_mm = feet_under_body(self._feet_mm(feet, self.stance), pose)
        return self._solve_feet(feet, feet_mm, fixed, step.where, "body")

    def _gait(self, step: StepT, gait: Gait, fixed: np.ndarray) -> list[StepT]:
        feet = self._feet(step.where, "gait:")
        if feet is None:
            return [step]
        if len(feet) != SIX_LEGS:
            self._fail(
                step.where,
                f"gait: patterns are for six legs; {self.robot.name!r} has {len(feet)} feet",
            )
            return [step]
        out = []
        # from the pose it is in (a body pose walks as it is), back to that pose at the end;
        # commanding more than asked where the robot is known to fall short (the preview judges
        # the walk against what was asked)
        commanded = compensated(gait, self.robot.gait)
        frames = gait_keyframes(self._feet_mm(feet, self.current), commanded)
        stances = []
        for index, frame in enumerate(frames):
            what = f"gait step {frame.step} of {gait.steps}"
            angles = self._solve_feet(feet, frame.feet_mm, fixed, step.where, what)
            if angles is None:
                return [step]
            stances.append(angles)
            last = index == len(frames) - 1
            end = GaitEnd(gait, len(frames), step.where) if last else None
            out.append(
                self._joint_step(
                    step, angles, after_s=gait.keyframe_s, t_s=None, stop=last, gait_end=end
                )
            )
        if self._too_heavy(feet, stances, step.where, [frame.step for frame in frames]):
            return [step]
        self.stance = self.current.copy()  # the feet are planted anew
        return out

    def _too_heavy(
        self,
        feet: Sequence[str],
        stances: list[np.ndarray],
        where: SourceLocation,
        steps: list[int],
    ) -> bool:
        """Told at the gait: line if the legs down cannot hold the robot up at some step.
        From the third step to the one before the last the feet stand under the body as in
        the third (the body moves on, the pattern repeats; the ripple's overlapping swings
        settle by then), so the first three and the last are judged: a long walk costs what a
        short one does."""
        from choreo.motion.stance_load import worst_overload

        judged = [i for i, number in enumerate(steps) if number <= 3 or number == steps[-1]]
        overload = worst_overload(self.kin, feet, [stances[i] for i in judged])
        if overload is None:
            return False
        o = overload
        at_step = steps[judged[o.keyframe]]
        supply = "its rated supply" if o.supply_v is None else f"{o.supply_v:g} V"
        self._fail(
            where,
            f"gait: at step {at_step}, on {o.feet_down} feet, {o.joint} needs "
            f"{o.needed_nm:.2f} N·m to hold the {o.mass_kg:.2f} kg robot up, more than its "
            f"servo's {o.stall_nm:.2f} N·m stall torque at {supply}: the legs would give way "
            "at any period; keep more feet down (pattern: ripple or wave), stand lower, or "
            "give the servos a higher supply",
        )
        return True


def compensated(gait: Gait, by: GaitCompensation) -> Gait:
    """The gait to command for ``gait`` on a robot that falls short of its plan as ``by`` says;
    a lift of 0 stays 0 (the feet are meant to slide)."""
    return replace(
        gait,
        stride_mm=gait.stride_mm * by.stride_scale,
        sideways_mm=gait.sideways_mm * by.stride_scale,
        turn_deg=gait.turn_deg * by.turn_scale,
        lift_mm=gait.lift_mm + by.lift_sag_mm if gait.lift_mm > 0 else 0.0,
    )


def _xyz(values: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return x, y, z


def _point(mm: Any) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in mm) + ")"


def has_key(node: Node, key: str) -> bool:
    return isinstance(node, yaml.MappingNode) and any(k.value == key for k, _ in node.value)
