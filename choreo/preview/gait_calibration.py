"""A legged robot's gait compensation (its ``gait:`` figures: lift sag, stride and turn scales)
found by walking it in the preview with its servos' figures, instead of by hand.

A short walk (``CALIBRATION_GAITS``: two steps forward, two sideways, two turning) is simulated
with no compensation; what the body and the swinging feet did against what was asked gives the
first figures (a stride covered at 94 % is commanded at 1/0.94, feet that rose 23 of 30 mm get
7 mm more), and the walk is simulated again with them and corrected by what is still missing.
With the servo table's assumed figures this finds hexapod18's stride scale as its robot file
was tuned by hand over its shipped walks (1.06), its turn scale and lift sag a little under
(1.125 against 1.16, 5.7 against 7 mm: the hand-tuned ones were rounded up over six-step walks
and the wave gait, which the feet rose 101-103 % of); with measured figures (slower, softer
servos sag and slip more) it finds that robot's own.

Each calibration is remembered (``check_cache``'s folder) under a digest of what it depends on:
the robot file, its model's folder, every joint's actuator figures and supply (the measured
ones included), the calibration walk and the code that simulates it; a few seconds of CPU
each time otherwise.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
from collections.abc import Sequence
from pathlib import Path

from choreo.core.yaml_source import Problems, SourceLocation
from choreo.errors import SourceError
from choreo.motion.gait import SIX_LEGS, Gait, Pattern
from choreo.motion.keyframe_entry import Step
from choreo.motion.motion_file import HOME_POSE, Keyframe, Motion
from choreo.motion.spatial import GaitSpec, expand_spatial
from choreo.preview.pipeline import simulate_motion
from choreo.robot import check_cache
from choreo.robot.types import GaitCompensation, Robot

log = logging.getLogger(__name__)

CALIBRATION_VERSION = "1"
# What is walked, as hexapod18's shipped walks do (their stride, lift and period), two steps
# each: forward and sideways give the stride scale (one figure for both: their mean), turning
# the turn scale, all three the lift sag (their mean).
STRIDE_MM, SIDEWAYS_MM, TURN_DEG, LIFT_MM, PERIOD_S, STEPS = 40.0, 30.0, 10.0, 30.0, 2.0, 2
FORWARD = Gait(Pattern.TRIPOD, STEPS, stride_mm=STRIDE_MM, lift_mm=LIFT_MM, period_s=PERIOD_S)
SIDEWAYS = Gait(
    Pattern.RIPPLE,
    STEPS,
    stride_mm=0.0,
    sideways_mm=SIDEWAYS_MM,
    lift_mm=LIFT_MM,
    period_s=PERIOD_S,
)
TURN = Gait(
    Pattern.TRIPOD, STEPS, stride_mm=0.0, turn_deg=TURN_DEG, lift_mm=LIFT_MM, period_s=PERIOD_S
)
CALIBRATION_GAITS = (FORWARD, SIDEWAYS, TURN)
ROUNDS = 2  # walks simulated: none compensated, then once corrected (a third moves < 0.5 %)
_CODE = Path(__file__).parents[1]  # choreo: the calibration depends on motion, plan and preview


def walks(robot: Robot) -> bool:
    """Whether ``robot`` walks the six-legged gaits (a free-floating robot with six feet)."""
    from choreo.robot.kinematics import Kinematics  # loads MuJoCo

    return robot.free_floating and len(Kinematics(robot).feet()) == SIX_LEGS


def calibrated_gait(robot: Robot) -> GaitCompensation:
    """The gait compensation that makes ``robot`` (its joints' actuator figures, measured or
    assumed) walk the calibration gaits as asked in the preview; remembered once found."""
    key = _key(robot)
    remembered = _remembered(key) if key else None
    if remembered is not None:
        return remembered
    found = _calibrate(robot)
    if key:
        _remember(key, found)
    return found


def _calibrate(robot: Robot) -> GaitCompensation:
    by = GaitCompensation()
    for _ in range(ROUNDS):
        forward, sideways, turn = gait_fractions(robot, by)
        lifts = (forward.lift, sideways.lift, turn.lift)
        by = GaitCompensation(
            lift_sag_mm=by.lift_sag_mm + LIFT_MM * (1 - sum(lifts) / len(lifts)),
            stride_scale=by.stride_scale / ((forward.travel + sideways.travel) / 2),
            turn_scale=by.turn_scale / turn.turn,
        )
        log.debug("gait calibration of %s: %s", robot.name, by)
    return GaitCompensation(
        round(by.lift_sag_mm, 1), round(by.stride_scale, 3), round(by.turn_scale, 3)
    )


@dataclasses.dataclass(frozen=True)
class Fractions:
    """What one calibration gait did, as shares of what it asked."""

    travel: float
    turn: float
    lift: float


def gait_fractions(robot: Robot, by: GaitCompensation) -> tuple[Fractions, ...]:
    """The calibration gaits walked in the preview by ``robot`` compensating as ``by`` says:
    for each, the travel, turn and swinging feet's rise against what it asked (1.0 where it
    asked none)."""
    simulated = simulate_motion(calibration_motion(dataclasses.replace(robot, gait=by)))
    return tuple(
        Fractions(
            outcome.travel_fraction or 1.0,
            outcome.turn_fraction or 1.0,
            outcome.lift_fraction or 1.0,
        )
        for outcome in simulated.gaits
    )


def calibration_motion(robot: Robot, gaits: Sequence[Gait] = CALIBRATION_GAITS) -> Motion:
    """``robot`` from its home pose walking ``gaits`` (compensated as its ``gait`` says)."""
    where = SourceLocation(robot.path, 1, 1)
    home = dict(robot.poses[HOME_POSE])
    steps = [Step(home, where, None, None, 0.0, True, 1.0, HOME_POSE, None)]
    for gait in gaits:
        steps.append(Step({}, where, None, None, 0.0, True, 1.0, "", None, GaitSpec(gait, where)))
    problems = Problems()
    expanded = expand_spatial(robot, steps, problems)
    if problems:  # the robot cannot walk the calibration gaits at all
        raise SourceError(problems.messages)
    keyframes = tuple(
        Keyframe(
            targets_deg=tuple(step.angles_deg[name] for name in robot.joint_names),
            where=step.where,
            hold_s=step.hold_s,
            stop=step.stop,
            label=step.label,
            gait_end=step.gait_end,
            after_s=step.after_s,
        )
        for step in expanded
    )
    return Motion("gait calibration", robot.path, robot, keyframes)


def _key(robot: Robot) -> str | None:
    models = [p for p in (robot.mjcf_path, robot.scene_path) if p is not None]
    model_key = check_cache.check_key(robot.path, models)
    if model_key is None:
        return None
    digest = hashlib.sha256(f"gait calibration {CALIBRATION_VERSION}\0{model_key}\0".encode())
    figures = [(j.name, sorted(j.actuator.items())) for j in robot.joints]
    digest.update(repr((figures, robot.bus.supply_v, CALIBRATION_GAITS)).encode())
    for folder in ("motion", "plan", "preview"):
        for code in sorted((_CODE / folder).glob("*.py")):
            digest.update(code.read_bytes())
    return digest.hexdigest()


def _remembered(key: str) -> GaitCompensation | None:
    text = check_cache.recall("gait-calibrations", key)
    try:
        return GaitCompensation(**json.loads(text)) if text is not None else None
    except (ValueError, TypeError):
        return None


def _remember(key: str, by: GaitCompensation) -> None:
    check_cache.keep("gait-calibrations", key, json.dumps(dataclasses.asdict(by)))
