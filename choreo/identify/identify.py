"""``choreo identify`` as one library call: measure each servo of the assembled robot where it
stands, fit its figures, judge them on held-out moves, and keep them in a servo figures file.

One joint at a time, the others holding the pose the robot stands in: the joint's test moves
(``moves``) run on the bus with reads as fast as it allows (``measure``), its neighbours in the
chain read in turn with it (they give way under its torque), its figures are fitted on a model
of that joint under the robot's own load with the neighbours yielding as servos do, their slow
motion from their reads (``fit``, ``joint_model``, ``neighbours``), and the file is written
after every joint, so a run stopped half way goes on from the next joint. Ctrl-C (and SIGTERM,
SIGHUP, which the CLI turns into it) stops every servo where it is, holding. A walker's gait
compensation is then recalibrated in the preview with the file's figures and written to it too
(``preview.gait_calibration``): the gaits make up for these servos' sag and slip, not the
assumed ones'.
"""

from __future__ import annotations

import datetime
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.atomic import write_text_atomically
from choreo.errors import OptionError, SourceError, UnsupportedByTransport
from choreo.identify import fit
from choreo.identify.fit import (
    Validation,
    assumed_figures,
    at_supply,
    fit_servo,
    validate,
)
from choreo.identify.joint_model import FIGURES
from choreo.identify.measure import Measured, Neighbour, run_moves
from choreo.identify.moves import fit_moves, held_out_moves, loaded_poses
from choreo.preview.actuator import ActuatorParams, actuator_params
from choreo.preview.gait_calibration import calibrated_gait, walks
from choreo.preview.joint_load import joint_load
from choreo.robot.robot_file import with_servo_figures
from choreo.robot.servo_figures import read_servo_figures
from choreo.robot.types import GaitCompensation, Joint, Robot

log = logging.getLogger(__name__)

READS_NEEDED = (
    (Command.POS_READ, "position"),
    (Command.VIN_READ, "supply voltage"),
    (Command.TEMP_READ, "temperature"),
)
SETTLE_S = 0.5  # after the others are told to hold, before the first joint moves
DECIMALS = {"response_delay_s": 4, "friction_nm": 4}  # figures kept to these decimals (else 3)
# a neighbour that gave way more than this under the joint's moves (4 read units) is told: the
# fit replays it, but the figures then hold for the joint in that chain, held that way
GAVE_WAY_DEG = 1.0


@dataclass(frozen=True)
class JointResult:
    """One joint's identification: its figures (at the servo model's rated supply, as a robot
    file's ``actuator:`` has them), how well they predict held-out moves, and the measurement."""

    joint: str
    figures: dict[str, float]
    validation: Validation
    reads_per_s: float
    supply_v: float
    temp_c: float
    bus_s: float  # bus time the joint's tests took
    fit_error_deg: float  # on the fit trial, the mean miss of the reads' units (fit.read_miss_deg)
    own_reads_per_s: float = 0.0  # of reads_per_s (every position read), the joint's own
    # how far each neighbour read along (its chain neighbours) went from where it held
    neighbours_moved_deg: dict[str, float] = field(default_factory=dict)

    @property
    def neighbours_gave_way(self) -> dict[str, float]:
        """The neighbours that moved more than ``GAVE_WAY_DEG`` under the joint's moves."""
        return {n: moved for n, moved in self.neighbours_moved_deg.items() if moved > GAVE_WAY_DEG}


@dataclass(frozen=True)
class Progress:
    joint: str
    index: int  # 0-based among the joints identified in this run
    count: int
    stage: str  # "test moves", "held-out moves", "fitting"
    fraction: float  # of this stage


@dataclass(frozen=True)
class IdentifyReport:
    path: Path
    identified: tuple[JointResult, ...]
    already: tuple[str, ...]  # in the file from an earlier run: not measured again
    # a walker's gait compensation, recalibrated in the preview with the file's figures (and
    # written to it); None for a robot that does not walk
    gait: GaitCompensation | None = None
    # why a walker's gait compensation could not be recalibrated (its gaits refused with
    # these figures: a stance too heavy for its servos), the file then has none
    gait_problem: str | None = None


def identify(
    robot: Robot,
    bus: ServoBus,
    output: Path,
    *,
    joints: Sequence[str] | None = None,
    drop: Sequence[str] = (),
    again: bool = False,
    generations: int | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    on_joint: Callable[[JointResult], None] | None = None,
) -> IdentifyReport:
    """Identify ``joints`` (default: all) of ``robot`` on ``bus`` and write ``output``; joints
    already in ``output`` are kept unless ``again``. ``drop``: joints whose torque may be
    switched off for a moment (they fall: only where that is safe). ``generations`` of the
    search per joint (default ``fit.GENERATIONS``): fewer is quicker and rougher."""
    generations = fit.GENERATIONS if generations is None else generations
    missing = [what for command, what in READS_NEEDED if not bus.capabilities.supports(command)]
    if missing:  # a board that drives PWM servos reads nothing; the LOBOT one no servo's supply
        raise UnsupportedByTransport(
            f"{bus.name}: the {bus.capabilities.transport} cannot read a servo's "
            f"{' or '.join(missing)}, which identify measures; connect the servos to a raw LX "
            "bus adapter (or an RRC board)"
        )
    names = _checked_joints(robot, joints, "joints")
    unknown_drop = [name for name in drop if name not in names]
    if unknown_drop:
        raise OptionError(
            "drop",
            f"names {', '.join(unknown_drop)}, which {'is' if len(unknown_drop) == 1 else 'are'} "
            f"not identified here; joints identified: {', '.join(names)}",
        )
    earlier = _earlier_results(output, robot)
    already = tuple(name for name in names if name in earlier.get("joints", {}) and not again)
    todo = [name for name in names if name not in already]
    pose = _hold_where_standing(bus, robot)
    params = actuator_params(robot)
    results: list[JointResult] = []
    # the figures measured so far (an earlier run's, then this one's): a joint's neighbours
    # are simulated with them where known, the robot file's otherwise
    known: dict[str, dict[str, float]] = dict(earlier.get("joints", {}))
    try:
        for index, name in enumerate(todo):
            result = _identify_joint(
                robot,
                bus,
                name,
                pose,
                params,
                {other: figures for other, figures in known.items() if other != name},
                name in drop,
                generations,
                (index, len(todo)),
                on_progress,
            )
            results.append(result)
            known[name] = result.figures
            _save(output, robot, bus, earlier, results)
            if on_joint is not None:
                on_joint(result)
    except KeyboardInterrupt:
        bus.stop_servos([joint.servo_id for joint in robot.joints])  # hold where they are
        raise
    gait, problem = _recalibrated_gait(output, robot)
    return IdentifyReport(output, tuple(results), already, gait, problem)


def _checked_joints(robot: Robot, joints: Sequence[str] | None, option: str) -> list[str]:
    if joints is None:
        return list(robot.joint_names)
    unknown = [name for name in joints if name not in robot.joint_names]
    if unknown:
        raise OptionError(
            option,
            f"names {', '.join(unknown)}: {robot.name} has no such joint; its joints: "
            f"{', '.join(robot.joint_names)}",
        )
    return list(dict.fromkeys(joints))


def _hold_where_standing(bus: ServoBus, robot: Robot) -> list[float]:
    """Every joint told to hold where it reads (which also switches its torque on); returns
    that pose (degrees, robot order)."""
    pose = []
    for joint in robot.joints:
        position = bus.read_position(joint.servo_id)
        bus.move(joint.servo_id, position, 300)
        pose.append(joint.to_deg(position))
    bus.clock.sleep_until(bus.clock.now() + SETTLE_S)
    return pose


def _identify_joint(
    robot: Robot,
    bus: ServoBus,
    name: str,
    pose: list[float],
    params: Sequence[ActuatorParams],
    known: Mapping[str, Mapping[str, float]],
    drop: bool,
    generations: int,
    place: tuple[int, int],
    on_progress: Callable[[Progress], None] | None,
) -> JointResult:
    """Measure joint ``name`` on the bus (its test moves, then the held-out ones), then fit
    its figures and judge them; its neighbours' servos have the figures ``known`` for
    them, if any."""
    index, count = place

    def progress(stage: str) -> Callable[[float], None]:
        def tell(fraction: float) -> None:
            if on_progress is not None:
                on_progress(Progress(name, index, count, stage, fraction))

        return tell

    j = robot.joint_names.index(name)
    load = joint_load(robot, name, pose, known)
    neighbours = [
        Neighbour(robot.joint(c.joint), pose[robot.joint_names.index(c.joint)])
        for c in load.neighbours
    ]
    loaded = loaded_poses(robot.joints[j], pose[j], load, params[j].stall_torque_nm)
    measured = _measure_joint(bus, robot.joints[j], pose[j], drop, loaded, neighbours, progress)
    progress("fitting")(0.0)
    supply_v = float(np.median(measured.fit.supply_v + measured.held_out.supply_v))
    assumed = at_supply(assumed_figures(params[j]), params[j].supply_v, supply_v)
    fitted = fit_servo(measured.fit.trial, load, assumed, with_offset=drop, generations=generations)
    validation = validate(
        measured.held_out.trial, load, assumed, fitted.figures, fitted.supply_sag_per_nm
    )
    rated = at_supply(fitted.figures, supply_v, params[j].rated_supply_v or supply_v)
    progress("fitting")(1.0)
    temps = measured.fit.temp_c + measured.held_out.temp_c
    return JointResult(
        name,
        _kept_figures(rated, drop),
        validation,
        measured.reads / measured.bus_s if measured.bus_s > 0 else 0.0,
        supply_v,
        max(temps) if temps else float("nan"),
        measured.bus_s,
        fitted.fit_error_deg,
        measured.own_reads / measured.bus_s if measured.bus_s > 0 else 0.0,
        measured.neighbours_moved_deg,
    )


@dataclass(frozen=True)
class _JointMeasured:
    fit: Measured  # the test moves the figures are fitted to
    held_out: Measured  # the moves that judge them
    bus_s: float  # bus time both took, with the move back to the pose

    @property
    def own_reads(self) -> int:
        return len(self.fit.trial.read_s) + len(self.held_out.trial.read_s)

    @property
    def reads(self) -> int:
        """Every position read, the neighbours' too."""
        trials = (self.fit.trial, self.held_out.trial)
        return self.own_reads + sum(len(n.read_s) for t in trials for n in t.neighbours)

    @property
    def neighbours_moved_deg(self) -> dict[str, float]:
        moved: dict[str, float] = {}
        for reads in self.fit.trial.neighbours + self.held_out.trial.neighbours:
            moved[reads.joint] = max(moved.get(reads.joint, 0.0), reads.moved_deg)
        return moved


def _measure_joint(
    bus: ServoBus,
    joint: Joint,
    pose_deg: float,
    drop: bool,
    loaded: tuple[float, ...],
    neighbours: Sequence[Neighbour],
    progress: Callable[[str], Callable[[float], None]],
) -> _JointMeasured:
    """``joint``'s test moves (with slow triangles at the ``loaded`` poses) and held-out moves
    on the bus, its ``neighbours`` read along, then back to where it stood."""
    start = bus.clock.now()
    fit_trial = run_moves(
        bus,
        joint,
        fit_moves(joint, pose_deg, drop, loaded),
        pose_deg,
        progress("test moves"),
        neighbours,
    )
    held_out = run_moves(
        bus,
        joint,
        held_out_moves(joint, pose_deg),
        fit_trial.trial.read_deg[-1],
        progress("held-out moves"),
        neighbours,
    )
    bus.move(joint.servo_id, round(joint.to_units(pose_deg)), 500)  # back to the pose
    return _JointMeasured(fit_trial, held_out, bus.clock.now() - start)


def _kept_figures(rated: dict[str, float], drop: bool) -> dict[str, float]:
    """The figures as the file keeps them: rounded, the offset only if a drop measured it."""
    return {
        key: round(value, DECIMALS.get(key, 3))
        for key, value in rated.items()
        if key in FIGURES and (drop or key != "offset_deg")
    }


def _recalibrated_gait(output: Path, robot: Robot) -> tuple[GaitCompensation | None, str | None]:
    """The walker's gait compensation recalibrated and written (``_recalibrate_gait``), or
    why it could not be; (None, None) for a robot that does not walk or no file."""
    if not output.exists():
        return None, None
    try:
        return _recalibrate_gait(output, robot), None
    except SourceError as error:  # the calibration gaits cannot be walked with these servos
        return None, "; ".join(error.problems)


def _recalibrate_gait(output: Path, robot: Robot) -> GaitCompensation | None:
    """A walker's gait compensation found again in the preview with the figures in
    ``output`` (remembered: a few seconds of CPU the first time), and written to it;
    ``SourceError`` if the robot cannot walk the calibration gaits with them (the file then
    keeps no gait: one an earlier run wrote was for other figures)."""
    if not walks(robot):
        return None
    try:
        gait = calibrated_gait(with_servo_figures(robot, read_servo_figures(output, robot)))
    except SourceError:
        _write_gait(output, None)
        raise
    _write_gait(output, gait)
    return gait


def _write_gait(output: Path, gait: GaitCompensation | None) -> None:
    text = output.read_text(encoding="utf-8")
    header = "".join(line for line in text.splitlines(keepends=True) if line.startswith("#"))
    document = {key: value for key, value in yaml.safe_load(text).items() if key != "gait"}
    if gait is not None:
        document["gait"] = {
            "lift_sag": gait.lift_sag_mm,
            "stride_scale": gait.stride_scale,
            "turn_scale": gait.turn_scale,
        }
    write_text_atomically(output, header + yaml.safe_dump(document, sort_keys=False))


def _earlier_results(output: Path, robot: Robot) -> dict:
    """What an earlier run wrote (its joints and their validation), if the file exists."""
    if not output.exists():
        return {}
    figures = read_servo_figures(output, robot)  # SourceError if it is not one
    return {
        "joints": {name: dict(values) for name, values in figures.joints.items()},
        "validation": dict(figures.extra.get("validation") or {}),
        "supply": figures.supply_v,
    }


def _save(
    output: Path, robot: Robot, bus: ServoBus, earlier: dict, results: list[JointResult]
) -> None:
    joints = dict(earlier.get("joints", {}))
    validation = dict(earlier.get("validation", {}))
    for result in results:
        joints[result.joint] = result.figures
        v = result.validation
        validation[result.joint] = {
            "held_out_reads": v.reads,
            "assumed_median_deg": round(v.default_median_deg, 3),
            "assumed_p95_deg": round(v.default_p95_deg, 3),
            "fitted_median_deg": round(v.fitted_median_deg, 3),
            "fitted_p95_deg": round(v.fitted_p95_deg, 3),
            "reads_per_s": round(result.reads_per_s, 1),
            "supply_v": round(result.supply_v, 2),
            "temperature_c": result.temp_c,
        }
        if result.neighbours_moved_deg:  # read along: how far each gave way under the joint
            validation[result.joint]["neighbours_moved_deg"] = {
                name: round(moved, 2) for name, moved in result.neighbours_moved_deg.items()
            }
    order = {name: i for i, name in enumerate(robot.joint_names)}
    document = {
        "robot": robot.name,
        "measured": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "transport": bus.capabilities.transport,
        "joints": dict(sorted(joints.items(), key=lambda item: order[item[0]])),
        "validation": dict(sorted(validation.items(), key=lambda item: order[item[0]])),
    }
    header = (
        f"# {robot.name}'s servos as `choreo identify` measured them (figures at each servo\n"
        "# model's rated supply, as a robot file's actuator: block has them). Name this file\n"
        "# in robot.yaml (servo_figures: FILE) for the preview, the planner and the gaits\n"
        "# (a walker's gait: is recalibrated in the preview with these figures).\n"
    )
    write_text_atomically(output, header + yaml.safe_dump(document, sort_keys=False))
