"""What the servos do with the ticks they receive: their own linear moves, and the actuator model.

Plain numpy, no MuJoCo: the simulation asks a ``ServoBank`` for every servo's set-point at each
physics step. Hardware behaviour modelled (see ``docs/protocol.md``), as the player sends:

- a staged move (position, time) is a preset; every tick's broadcast START runs each servo's
  preset, so a servo that was not re-staged re-runs its previous one (the first tick is staged on
  every servo; a tick that stages nothing sends no START);
- a move is linear from where the servo is (``sim.MoveStart`` says which "where") to the target;
- the servo caps its speed at the motor's no-load speed (a time too short just means full speed).

``ServoDrive`` is the servo's law at every physics step, the same for the preview and for the
emulated robot whose servos are the physics (``preview/twin.py``): the set-point, late by the
servo's response delay, is aimed at through the horn's offset; gear play (backlash) lets the aim
turn that far back before the output is pulled the other way; errors inside the dead band make
no torque; past it, MuJoCo's position actuator pushes with the gain up to the stall torque.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from choreo.bus.servo_models import (
    ACTUATOR_FIELDS,
    DEG_PER_UNIT,
    MAX_RESPONSE_DELAY_S,
    POSITION_RANGE_UNITS,
    SIGNED_ACTUATOR_FIELDS,
    ZERO_OK_ACTUATOR_FIELDS,
    servo_model,
)
from choreo.core.arguments import shown
from choreo.errors import OptionError
from choreo.plan.ticks import MAX_TICK_MS, Tick
from choreo.robot.types import Joint, Robot

INSTANT_S = 1e-9  # the duration that stands for "at once" (avoids dividing by zero)
ROUNDING = 1e-9  # two servo states this close are the same but for float rounding


@dataclass(frozen=True)
class ActuatorParams:
    """One joint's servo as MuJoCo sees it (SI units) at its supply voltage, plus its speed cap
    and the assumptions made (supply, dead band, backlash)."""

    stall_torque_nm: float
    kp_nm_rad: float
    damping_nm_s_rad: float
    armature_kg_m2: float
    no_load_speed_deg_s: float
    supply_v: float
    deadband_deg: float
    backlash_deg: float
    rated_supply_v: float = 0.0  # the supply the datasheet figures are for (0: not given)
    friction_nm: float = 0.0  # dry friction at the output
    response_delay_s: float = 0.0  # from a command to the servo acting on it
    offset_deg: float = 0.0  # where the joint really is when the servo aims at 0


def actuator_params(
    robot: Robot,
    overrides: Mapping[str, Mapping[str, float]] | None = None,
) -> tuple[ActuatorParams, ...]:
    """Every joint's actuator model from its servo model, then the robot file's ``bus:
    supply_v`` and each joint's ``actuator:`` values, then per-joint ``overrides`` (joint name ->
    {field of ``ActuatorParams``: value})."""
    overrides = checked_overrides(overrides, robot)
    supply = robot.bus.supply_v
    return tuple(
        _params_for(
            joint,
            {
                **({"supply_v": supply} if supply else {}),
                **joint.actuator,
                **overrides.get(joint.name, {}),
            },
        )
        for joint in robot.joints
    )


# Where each figure of a joint's servo model comes from when nothing else gives it.
DEFAULT_SOURCES = {
    "stall_torque_nm": "datasheet",
    "no_load_speed_deg_s": "datasheet",
    "kp_nm_rad": "modelling choice",
    "damping_nm_s_rad": "modelling choice",
    "armature_kg_m2": "modelling choice",
    "supply_v": "rated",
    "deadband_deg": "assumed",
    "backlash_deg": "assumed",
    # none unless measured or given: the model leaves them out rather than guess them
    "friction_nm": "assumed none",
    "response_delay_s": "assumed none",
    "offset_deg": "assumed none",
}
ROBOT_FILE_SOURCE = "robot file"


@dataclass(frozen=True)
class FigureSource:
    """Where one servo figure of some joints comes from: a ``DEFAULT_SOURCES`` value, the robot
    file, or the servo figures file it names (``source``: that file's name; ``measured_on``:
    when ``choreo identify`` measured it, as the file's ``measured:`` says)."""

    figure: str  # an ActuatorParams field
    source: str
    joints: tuple[str, ...]
    measured_on: str | None = None

    @property
    def measured(self) -> bool:
        return self.measured_on is not None

    def to_dict(self) -> dict:
        return {
            "figure": self.figure,
            "source": self.source,
            "joints": list(self.joints),
            "measured": self.measured,
            "measured_on": self.measured_on,
        }


def figure_sources(robot: Robot) -> tuple[FigureSource, ...]:
    """Each figure of the servo model, grouped by where it comes from, joints in robot order:
    the servo figures file the robot file names (measured when the file says when), else the
    robot file's ``bus: supply_v`` and ``actuator:`` values, else the defaults."""
    figures = robot.servo_figures
    measured_on = None
    if figures is not None and figures.extra.get("measured") is not None:
        measured_on = str(figures.extra["measured"])
    joints_by: dict[tuple[str, str, str | None], list[str]] = {}
    for joint in robot.joints:
        in_file = figures.joints.get(joint.name, {}) if figures is not None else {}
        for figure, default in DEFAULT_SOURCES.items():
            if figure in in_file:
                key = (figure, figures.path.name, measured_on)  # type: ignore[union-attr]
            elif figure in joint.actuator or (figure == "supply_v" and robot.bus.supply_v):
                key = (figure, ROBOT_FILE_SOURCE, None)
            else:
                key = (figure, default, None)
            joints_by.setdefault(key, []).append(joint.name)
    return tuple(
        FigureSource(figure, source, tuple(joints), when)
        for (figure, source, when), joints in joints_by.items()
    )


def _params_for(joint: Joint, override: Mapping[str, float]) -> ActuatorParams:
    """The servo model's figures with ``override`` applied; torque, gain and speed then scale
    with the supply (a PWM servo's drive voltage is the supply times its duty; back-EMF
    damping does not depend on it, so no-load speed = stall torque / damping scales too)."""
    model = servo_model(joint.servo_model)
    values = {
        "stall_torque_nm": model.stall_torque_nm,
        "kp_nm_rad": model.kp_nm_rad,
        "damping_nm_s_rad": model.damping_nm_s_rad,
        "armature_kg_m2": model.armature_kg_m2,
        "no_load_speed_deg_s": model.no_load_speed_deg_s,
        "supply_v": model.rated_supply_v,
        "deadband_deg": model.deadband_deg,
        "backlash_deg": model.backlash_deg,
        "friction_nm": 0.0,
        "response_delay_s": 0.0,
        "offset_deg": 0.0,
    }
    for key, value in override.items():
        if key not in values:
            raise ValueError(
                f"unknown actuator field {key!r} for joint {joint.name}; "
                f"valid fields: {', '.join(ACTUATOR_FIELDS)}"
            )
        check_actuator_value(key, value, f"actuator field {key} of joint {joint.name}")
        values[key] = float(value)
    if "damping_nm_s_rad" not in override:  # back-EMF: no-load speed = stall torque / damping
        values["damping_nm_s_rad"] = values["stall_torque_nm"] / math.radians(
            values["no_load_speed_deg_s"]
        )
    scale = model.supply_scale(values["supply_v"])
    for key in ("stall_torque_nm", "kp_nm_rad", "no_load_speed_deg_s"):
        values[key] *= scale
    return ActuatorParams(**values, rated_supply_v=model.rated_supply_v)


OVERRIDES_EXAMPLE = "{'elbow': {'stall_torque_nm': 0.5}}"


def checked_overrides(overrides: object, robot: Robot | None = None) -> dict[str, Mapping]:
    """``overrides`` (joint name -> {field of ``ActuatorParams``: value}) as a dict, if every
    field and value is one a servo model takes and, given ``robot``, every joint is one of its
    joints; an ``OptionError`` naming ``actuator_overrides`` otherwise (a program's argument:
    robot and figures files are checked as they are read)."""
    if overrides is None:
        return {}
    if not isinstance(overrides, Mapping) or not all(
        isinstance(name, str) and isinstance(fields, Mapping) for name, fields in overrides.items()
    ):
        raise OptionError(
            "actuator_overrides",
            f"must map joint names to {{field: value}}, e.g. {OVERRIDES_EXAMPLE}, or be None, "
            f"got {shown(overrides)}",
        )
    for name, fields in overrides.items():
        for key, value in fields.items():
            if key not in ACTUATOR_FIELDS:
                raise OptionError(
                    "actuator_overrides",
                    f"gives {name} the unknown field {key!r}; the fields: "
                    f"{', '.join(ACTUATOR_FIELDS)}",
                )
            try:
                check_actuator_value(key, value, key)
            except ValueError:
                raise OptionError(
                    "actuator_overrides",
                    f"gives {name}'s {key} {shown(value)}; it must be {actuator_values(key)}",
                ) from None
    unknown = sorted(set(overrides) - set(robot.joint_names)) if robot else []
    if robot and unknown:
        raise OptionError(
            "actuator_overrides",
            f"names unknown joints {', '.join(unknown)}; joints of {robot.name}: "
            f"{', '.join(robot.joint_names)}",
        )
    return dict(overrides)


def check_actuator_value(key: str, value: object, what: str) -> float:
    """``value`` if it is valid for the actuator field ``key`` (``what`` names it in the
    ``ValueError`` otherwise)."""
    zero_ok = key in ZERO_OK_ACTUATOR_FIELDS
    signed = key in SIGNED_ACTUATOR_FIELDS
    high = MAX_RESPONSE_DELAY_S if key == "response_delay_s" else math.inf
    if not (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and abs(value) <= sys.float_info.max  # finite, and an int no float is too large for
        and (signed or (value >= 0 if zero_ok else value > 0))
        and value <= high
    ):
        raise ValueError(f"{what} must be {actuator_values(key)}, got {value!r}")
    return float(value)


def actuator_values(key: str) -> str:
    """The values the actuator field ``key`` takes, in words: ``a number > 0``."""
    bound = (
        ""
        if key in SIGNED_ACTUATOR_FIELDS
        else " >= 0"
        if key in ZERO_OK_ACTUATOR_FIELDS
        else " > 0"
    )
    if key == "response_delay_s":
        bound += f" and <= {MAX_RESPONSE_DELAY_S:g}"
    return "a number" + bound


class ServoDrive:
    """Every servo's law at each physics step (radians, robot joint order): what it asks the
    position actuator for, given its set-point and where the joint is. Keeps the state the law
    needs: the set-points not yet acted on (the response delay) and the aim left by the gear
    play."""

    def __init__(self, params: Sequence[ActuatorParams], dt_s: float, initial_rad: np.ndarray):
        n = len(params)
        self.offset_rad = np.radians([p.offset_deg for p in params])
        self.half_play_rad = np.radians([p.backlash_deg for p in params]) / 2
        self.half_band_rad = np.radians([p.deadband_deg for p in params]) / 2
        self._minus_half_band_rad = -self.half_band_rad
        # a delay between two steps acts on the set-point between theirs (as identify's joint
        # model has it): rounded to whole steps, a 3.7 ms delay would act as 4 ms
        steps = np.array([p.response_delay_s / dt_s for p in params], dtype=float)
        steps = np.where(np.isclose(steps, np.round(steps)), np.round(steps), steps)
        self.delay_steps = np.floor(steps).astype(int)
        self._delay_part = steps - self.delay_steps
        depth = int((self.delay_steps + (self._delay_part > 0)).max(initial=0)) + 1
        # the last set-points, oldest first (a copy of the last rows each step: a ring's two
        # rolls cost the emulated robot's twin, which steps one at a time, more than its step)
        self._history = np.tile(np.asarray(initial_rad, dtype=float), (depth, 1))
        self._columns = np.arange(n)
        # without a delay the set-point is acted on as it comes: ``late + (older - late) * 0``
        # is ``late`` but for a zero's sign, which adding an offset of +0.0 (never -0.0) gives
        self._offset_undelayed_rad = self.offset_rad + 0.0
        self.aim_rad = np.asarray(initial_rad, dtype=float) + self.offset_rad
        self._error = np.empty(n)

    def ctrl(
        self, setpoint_rad: np.ndarray, position_rad: np.ndarray, out: np.ndarray | None = None
    ) -> np.ndarray:
        """One step: the actuator's control for the set-points of this step (into ``out`` if
        given)."""
        low, high = self.play_edges(np.asarray(setpoint_rad, dtype=float)[None])
        return self.follow(low[0], high[0], position_rad, out)

    def play_edges(self, setpoints_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The set-points of the next steps (one row each) as the servos act on them (late by
        their delay, through their offset), less and plus the half play: the edges each step's
        aim is kept within (``follow``). The delay line moves on by those steps. Known ahead
        for a stretch of steps, as between two STARTs, they are worked out for all at once:
        for a handful of servos numpy's cost is per call, not per element."""
        wanted = self._acted_on(setpoints_rad)
        return wanted - self.half_play_rad, wanted + self.half_play_rad

    def edges_ahead(self, setpoints_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``play_edges`` of set-points that may not all be reached (a servo driven anew cuts
        them short), the delay line left where it is; with the line, for ``move_on``."""
        line = np.concatenate((self._history, setpoints_rad))  # oldest first
        wanted = self._delayed(line, len(setpoints_rad))
        return wanted - self.half_play_rad, wanted + self.half_play_rad, line

    def move_on(self, line: np.ndarray, steps: int) -> None:
        """The delay line moved on by the first ``steps`` set-points of ``line`` (from
        ``edges_ahead``), as ``play_edges`` of those would have moved it."""
        self._history = line[steps : steps + len(self._history)].copy()

    def _acted_on(self, setpoints_rad: np.ndarray) -> np.ndarray:
        history, steps = self._history, len(setpoints_rad)
        depth = len(history)
        if depth == 1:
            history[0] = setpoints_rad[-1]
            return setpoints_rad + self._offset_undelayed_rad
        line = np.concatenate((history, setpoints_rad))  # oldest first
        self._history = line[-depth:].copy()
        return self._delayed(line, steps)

    def _delayed(self, line: np.ndarray, steps: int) -> np.ndarray:
        """The last ``steps`` rows of ``line`` (the delay line, then the new set-points) as
        the servos act on them."""
        depth = len(line) - steps
        if depth == 1:
            return line[1:] + self._offset_undelayed_rad
        late_at = np.arange(depth, depth + steps)[:, None] - self.delay_steps
        late, older = line[late_at, self._columns], line[late_at - 1, self._columns]
        return late + (older - late) * self._delay_part + self.offset_rad

    def follow(
        self,
        low_rad: np.ndarray,
        high_rad: np.ndarray,
        position_rad: np.ndarray,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """One step: the actuator's control (into ``out`` if given), the aim kept within the
        step's ``play_edges``, for the joints at ``position_rad``. It runs at every physics
        step: as few numpy calls as the law allows, into buffers kept."""
        aim = self.aim_rad
        np.maximum(aim, low_rad, out=aim)
        np.minimum(aim, high_rad, out=aim)
        error = np.subtract(aim, position_rad, out=self._error)
        np.maximum(error, self._minus_half_band_rad, out=error)
        np.minimum(error, self.half_band_rad, out=error)
        return np.subtract(aim, error, out=out)

    def same_as(self, other: ServoDrive, tolerance_rad: float) -> bool:
        """Whether ``other`` (of the same servos) goes on as this one does: the same set-points
        waiting out the delay (but for float rounding), and aims within ``tolerance_rad`` (the
        gear play holds an aim where it was left, as the dead band holds a joint, so a
        tolerance and not equality)."""
        return np.allclose(self._history, other._history, rtol=0.0, atol=ROUNDING) and bool(
            np.abs(self.aim_rad - other.aim_rad).max(initial=0.0) <= tolerance_rad
        )


@dataclass(frozen=True)
class CommandStream:
    """The tick list as arrays, checked: what goes out on the bus, in time order."""

    start_s: np.ndarray  # (n_ticks,)
    duration_s: np.ndarray  # (n_ticks,)
    targets_units: np.ndarray  # (n_ticks, n_joints)
    staged: np.ndarray  # (n_ticks, n_joints) bool: this servo gets a new preset for the tick
    started: np.ndarray  # (n_ticks,) bool: the tick's broadcast START is sent

    @classmethod
    def from_ticks(cls, ticks: Sequence[Tick], n_joints: int) -> CommandStream:
        """As the player sends it: the first tick is staged on every servo, and a later tick
        that stages nothing sends no START (so nothing re-runs its preset)."""
        low, high = POSITION_RANGE_UNITS
        previous_start = -math.inf
        for index, tick in enumerate(ticks):
            where = f"tick {index} (start {tick.start_ms} ms)"
            if len(tick.targets_units) != n_joints or len(tick.staged) != n_joints:
                raise ValueError(
                    f"{where}: needs {n_joints} targets and staged flags (one per "
                    f"joint), got {len(tick.targets_units)} and {len(tick.staged)}"
                )
            if tick.start_ms < previous_start:
                raise ValueError(
                    f"{where}: ticks must be in time order "
                    f"(the previous one starts at {previous_start} ms)"
                )
            if not 0 <= tick.duration_ms <= MAX_TICK_MS:
                raise ValueError(
                    f"{where}: duration {tick.duration_ms} ms is outside 0..{MAX_TICK_MS}"
                )
            bad = [u for u in tick.targets_units if not low <= u <= high]
            if bad:
                raise ValueError(f"{where}: servo positions {bad} are outside {low}..{high}")
            previous_start = tick.start_ms
        staged = np.array([t.staged for t in ticks], dtype=bool).reshape(len(ticks), n_joints)
        staged[:1] = True
        return cls(
            start_s=np.array([t.start_ms for t in ticks], dtype=float) / 1000.0,
            duration_s=np.array([t.duration_ms for t in ticks], dtype=float) / 1000.0,
            targets_units=np.array([t.targets_units for t in ticks], dtype=float).reshape(
                len(ticks), n_joints
            ),
            staged=staged,
            started=np.asarray(staged.any(axis=1)),  # numpy types any(axis=) as maybe a scalar
        )

    @property
    def end_s(self) -> float:
        """When the last commanded move is due to finish (0 without ticks)."""
        return float(np.max(self.start_s + self.duration_s, initial=0.0))


class ServoBank:
    """Every servo's preset and current linear move; ``setpoint_units`` is where each one's
    own interpolation is at a given time (never before the move's start)."""

    def __init__(self, initial_units: np.ndarray, max_speed_units_s: np.ndarray | None):
        n = len(initial_units)
        self._preset_units = np.full(n, np.nan)
        self._preset_duration_s = np.zeros(n)
        self._from_units = np.array(initial_units, dtype=float)
        self._delta_units = np.zeros(n)
        self._start_s = np.zeros(n)
        self._rate_per_s = np.full(n, 1 / INSTANT_S)  # 1 / move duration
        self._max_speed_units_s = max_speed_units_s

    def start(
        self, stream: CommandStream, tick: int, now_s: float, position_units: np.ndarray
    ) -> None:
        """Tick ``tick``'s presets arrive and its START runs every servo that has a preset."""
        staged = stream.staged[tick]
        self._preset_units[staged] = stream.targets_units[tick, staged]
        self._preset_duration_s[staged] = stream.duration_s[tick]
        runs = ~np.isnan(self._preset_units)
        delta = self._preset_units[runs] - position_units[runs]
        duration = self._preset_duration_s[runs]
        if self._max_speed_units_s is not None:
            duration = np.maximum(duration, np.abs(delta) / self._max_speed_units_s[runs])
        self._from_units[runs] = position_units[runs]
        self._delta_units[runs] = delta
        self._start_s[runs] = now_s
        # a zero-time move (possible only without a speed cap) jumps at once
        self._rate_per_s[runs] = 1 / np.maximum(duration, INSTANT_S)

    def _resting(self, now_s: float) -> np.ndarray:
        """Per servo: it stands at its preset's target (or has none) from ``now_s`` on, its move
        over or going nowhere, so re-running the preset moves it nowhere, however long that
        was to take."""
        done = (now_s - self._start_s) * self._rate_per_s >= 1.0
        still = done | (np.abs(self._delta_units) <= ROUNDING)
        there = ~(np.abs(self.setpoint_units(now_s) - self._preset_units) > ROUNDING)
        return still & there  # a servo without a preset (NaN) is never re-run: there

    def same_as(self, other: ServoBank, now_s: float) -> bool:
        """Whether ``other`` (of the same servos) gives the same set-points as this one from
        ``now_s`` on, for the same ticks: the same presets' targets; a servo resting on its
        target (``_resting``) standing at the same place, any other with the same move and
        preset duration. Equal but for float rounding (``from + (target - from)`` is
        ``target`` only to the last bit)."""
        resting = self._resting(now_s)
        if not np.array_equal(resting, other._resting(now_s)):
            return False
        moving = ~resting
        pairs = [
            (self._preset_units, other._preset_units),
            (self.setpoint_units(now_s), other.setpoint_units(now_s)),
        ]
        for name in (
            "_preset_duration_s",
            "_from_units",
            "_delta_units",
            "_start_s",
            "_rate_per_s",
        ):
            pairs.append((getattr(self, name)[moving], getattr(other, name)[moving]))
        return all(
            np.allclose(ours, theirs, rtol=ROUNDING, atol=ROUNDING, equal_nan=True)
            for ours, theirs in pairs
        )

    def setpoint_units(self, now_s: float | np.ndarray) -> np.ndarray:
        """Set-points at one time (n_joints,) or at an array of times (n_times, n_joints)."""
        elapsed = np.asarray(now_s, dtype=float)[..., None] - self._start_s
        progress = np.minimum(elapsed * self._rate_per_s, 1.0)
        return self._from_units + self._delta_units * progress


def max_speed_units_s(params: Sequence[ActuatorParams]) -> np.ndarray:
    """Each servo's no-load speed in position units per second."""
    return np.array([p.no_load_speed_deg_s / DEG_PER_UNIT for p in params], dtype=float)


def commanded_path_units(
    stream: CommandStream, initial_units: np.ndarray, times_s: np.ndarray
) -> np.ndarray:
    """Where a servo with no load, no lag and no speed cap would be at ``times_s``: the path the
    tick list asks for, as the reference for tracking errors. Shape (len(times_s), n_joints)."""
    bank = ServoBank(initial_units, max_speed_units_s=None)
    path = np.empty((len(times_s), len(initial_units)))
    started = np.flatnonzero(stream.started)
    boundaries = np.searchsorted(times_s, stream.start_s[started], side="left")
    path[: boundaries[0] if len(boundaries) else len(times_s)] = initial_units
    for k, (tick, begin) in enumerate(zip(started.tolist(), boundaries)):
        start_s = stream.start_s[tick]
        bank.start(stream, tick, start_s, bank.setpoint_units(start_s))
        end = boundaries[k + 1] if k + 1 < len(boundaries) else len(times_s)
        path[begin:end] = bank.setpoint_units(times_s[begin:end])
    return path
