"""An emulated robot whose servos are the physics: ``sim://?physics=ROBOT&truth=FILE``.

The robot's MuJoCo model, made into its servos as the preview makes it (``model.py``), driven by
the preview's servo law (``actuator.ServoDrive``): the same model ``choreo preview`` simulates,
so what a motion does on this bus is what the preview predicts, and a truth file (a servo
figures file, ``robot/servo_figures.py``) can make the servos differ from the robot file's
assumed figures, as a real robot's do.

The world is stepped lazily on the bus's clock: whenever a servo is commanded or read at time
t, every physics step before t is run first, each with the set-points the servos had then (their
own linear moves: between two commands a known function of time), so a virtual clock gives the
same result however fast it runs, and a real clock runs in real time.

Beyond the preview's model, the world keeps:

- the supply: it sags by its internal resistance times the current the servos draw (idle, plus
  the stall current in proportion to each servo's torque), and the servos' torque and gain sag
  with it;
- each servo's temperature: it rises towards ``RISE_AT_STALL_C`` above the ambient in proportion
  to the square of its torque (copper losses), with a time constant of ``THERMAL_TIME_S``.

Both are modelling choices, not vendor data: the servos' data sheets give neither.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from choreo.bus.servo_models import DEG_PER_UNIT
from choreo.core.clock import Clock
from choreo.emulator.physics import PhysicalServo, SetPoint
from choreo.preview.actuator import ActuatorParams, ServoDrive, actuator_params
from choreo.preview.model import apply_servo_models, free_joint, index_joints, load_model
from choreo.preview.start import start_state
from choreo.preview.step_loop import as_slice, check_stable, hold_until_still
from choreo.robot.poses import HOME_POSE
from choreo.robot.robot_file import load_robot
from choreo.robot.servo_figures import (
    DEFAULT_SUPPLY_RESISTANCE_OHM,
    ServoFigures,
    read_servo_figures,
)
from choreo.robot.types import Robot

AMBIENT_C = 30.0  # what an emulated servo reads at rest (the emulator's factory temperature)
RISE_AT_STALL_C = 70.0  # held at stall torque for good, a servo would settle this much warmer
THERMAL_TIME_S = 120.0
IDLE_CURRENT_A = 0.05  # each servo's electronics
STALL_CURRENT_A = 2.5  # at stall torque (HTD-35H: 3 A; the LX models are not given)
SETTLE_S = 2.0  # the start pose is held until the robot is still, at most this long
STAND_LIFT_M = 0.08  # a free-floating robot on a stand: its body this far above standing
SAG_STEP = 0.002  # the servos' torque follows the supply in steps this fine (a fifth of 1 %)
TRACE_LIMIT = 200_000  # physics steps kept in the trace (400 s at 2 ms)
STEPS_AT_ONCE = 4096  # set-points computed together (a long wait needs no more memory)
# set-points computed ahead of the steps asked for (until a servo is driven anew): a bus read
# every 2 ms asks for one step at a time, whose set-points cost a dozen numpy calls each
STEPS_AHEAD = 256


@dataclass(frozen=True)
class TraceStep:
    """One physics step, for tests and benchmarks: its bus time, where the joints really were
    (degrees, robot order), and the supply."""

    time_s: float
    position_deg: np.ndarray
    supply_v: float


class PhysicsTwin:
    """The robot's world behind an emulated bus (``choreo.emulator.physics.Physics``)."""

    def __init__(
        self, robot: Robot, figures: ServoFigures | None, clock: Clock, *, stand: bool = False
    ):
        self.robot = robot
        self.figures = figures
        overrides = {
            name: dict(values) for name, values in (figures.joints if figures else {}).items()
        }
        if figures is not None and figures.supply_v is not None:
            for joint in robot.joints:
                overrides.setdefault(joint.name, {}).setdefault("supply_v", figures.supply_v)
        self.actuators: tuple[ActuatorParams, ...] = actuator_params(robot, overrides)
        self.supply_v = self.actuators[0].supply_v if self.actuators else 0.0
        self.resistance_ohm = (
            figures.supply_resistance_ohm if figures else DEFAULT_SUPPLY_RESISTANCE_OHM
        )
        self._clock = clock
        self._model = _on_a_stand(robot) if stand and robot.free_floating else load_model(robot)
        self._index = index_joints(self._model, robot)
        apply_servo_models(self._model, self._index, self.actuators, robot)
        self.dt_s = float(self._model.opt.timestep)
        home = np.array(
            robot.pose_vector(HOME_POSE) if HOME_POSE in robot.poses else [0.0] * len(robot.joints)
        )
        self._data = start_state(self._model, self._index, home)
        self._drive = ServoDrive(self.actuators, self.dt_s, np.radians(home))
        n = len(robot.joints)
        self._stall_nm = np.array([a.stall_torque_nm for a in self.actuators])
        self._kp = np.array([a.kp_nm_rad for a in self.actuators])
        self._offset_deg = np.array([a.offset_deg for a in self.actuators])
        self._zero = np.array([j.zero_units for j in robot.joints], dtype=float)
        self._direction = np.array([j.direction for j in robot.joints], dtype=float)
        home_units = robot.to_units(home)
        self._start_s = np.zeros(n)
        self._start_units = np.array(home_units, dtype=float)
        self._velocity = np.zeros(n)
        self._end_s = np.full(n, -math.inf)
        self._supply_now_v = self.supply_v
        self._idle_a = IDLE_CURRENT_A * n
        self._sag = 1.0
        self._per_stall = 1 / np.maximum(self._stall_nm, 1e-9)
        self._temp_c = np.full(n, AMBIENT_C)
        # a step's arrays, kept: each step is a dozen numpy calls on a handful of servos, whose
        # cost is per call (views and buffers rather than copies, as ``StepLoop`` has them)
        self._joint_qpos = as_slice(self._index.qpos)
        self._actuator_at = as_slice(self._index.actuator)
        self._unloaded = np.zeros(n, dtype=bool)
        self._any_unloaded = False
        self._loaded_share = np.ones(n)  # 1.0 for a loaded servo: its current counts
        self._ctrl, self._load, self._heat, self._cooling = np.empty((4, n))
        # the thermal law's figures as arrays (numpy converts a Python float at each call)
        self._rise_c = np.full(n, RISE_AT_STALL_C)
        self._ambient_c = np.full(n, AMBIENT_C)
        self._per_step_of_thermal_time = np.full(n, self.dt_s / THERMAL_TIME_S)
        # the trace: a ring of the last TRACE_LIMIT steps (grown as they come), step k's row
        # at (k - 1) % TRACE_LIMIT, made into ``TraceStep`` only when asked for
        self._trace_rad, self._trace_v = np.empty((0, n)), np.empty(0)
        hold = np.radians(home)[None]
        hold_until_still(
            self._data,
            self.dt_s,
            lambda: self._step_physics(*(edges[0] for edges in self._drive.play_edges(hold))),
            round(SETTLE_S / self.dt_s),
        )
        self._origin_s = clock.now()  # bus time of the settled state
        self._steps = 0
        # the play edges of steps _ahead_from... worked out ahead (none: rows 0), and the delay
        # line they were worked out on (``ServoDrive.edges_ahead``; None: moved on)
        self._ahead_low = self._ahead_high = np.empty((0, n))
        self._ahead_from = 0
        self._ahead_line: np.ndarray | None = None
        self.servos: tuple[PhysicalServo, ...] = tuple(
            PhysicalServo(
                j.servo_id,
                j.servo_model,
                float(u),
                _ServoInWorld(self, i),
                # its own moves capped at its speed at the supply, as the preview's ServoBank
                # caps them: a faster or slower servo than the datasheet's (a truth file) is
                # so on the bus too
                top_speed_deg_s=a.no_load_speed_deg_s,
            )
            for i, (j, u, a) in enumerate(zip(robot.joints, home_units, self.actuators))
        )

    # --- what the servos see ---------------------------------------------------------------
    def position_deg(self, time_s: float) -> np.ndarray:
        """Where the joints really are at bus time ``time_s`` (robot order)."""
        self.advance_to(time_s)
        return np.degrees(self._data.qpos[self._joint_qpos])

    def body_position_m(self, time_s: float) -> np.ndarray | None:
        """Where a free-floating robot's body is at bus time ``time_s`` (world frame, m): how
        far the emulated robot really walked (None on a stand, or for a robot fixed to the
        world)."""
        joint = free_joint(self._model)
        if joint is None:
            return None
        self.advance_to(time_s)
        address = int(self._model.jnt_qposadr[joint])
        return self._data.qpos[address : address + 3].copy()

    def output_units(self, joint: int, time_s: float) -> float:
        """Joint ``joint``'s servo's horn as its potentiometer has it: the real angle less the
        horn's offset, in position units."""
        real_deg = self.position_deg(time_s)[joint]
        return float(self.robot.joints[joint].to_units(real_deg - self._offset_deg[joint]))

    def supply_at(self, time_s: float) -> float:
        self.advance_to(time_s)
        return self._supply_now_v

    def temp_at(self, joint: int, time_s: float) -> float:
        self.advance_to(time_s)
        return float(self._temp_c[joint])

    def drive(self, joint: int, time_s: float, setpoint: SetPoint, loaded: bool) -> None:
        self.advance_to(time_s)
        self._start_s[joint] = setpoint.start_s
        self._start_units[joint] = setpoint.start_units
        self._velocity[joint] = setpoint.velocity_units_s
        self._end_s[joint] = setpoint.end_s
        self._unloaded[joint] = not loaded
        self._any_unloaded = bool(self._unloaded.any())
        self._loaded_share[joint] = float(loaded)
        self._stop_ahead()  # worked out for the old moves

    # --- stepping --------------------------------------------------------------------------
    def advance_to(self, time_s: float) -> None:
        """Run every physics step due before bus time ``time_s``."""
        due = math.ceil((time_s - self._origin_s) / self.dt_s - 1e-9)
        if due <= self._steps:
            return
        qpos, joints = self._data.qpos, self._joint_qpos
        while self._steps < due:
            low, high = self._edges_ahead(min(due, self._steps + STEPS_AT_ONCE))
            self._make_room(self._steps + len(low))
            for low_rad, high_rad in zip(low, high):
                self._step_physics(low_rad, high_rad)
                row = self._steps % TRACE_LIMIT
                self._trace_rad[row] = qpos[joints]
                self._trace_v[row] = self._supply_now_v
                self._steps += 1
        check_stable(self._model, self._data)

    @property
    def trace(self) -> list[TraceStep]:
        """The last ``TRACE_LIMIT`` physics steps, oldest first."""
        steps = np.arange(max(self._steps - TRACE_LIMIT, 0), self._steps) + 1
        rows = (steps - 1) % TRACE_LIMIT
        times_s = self._origin_s + steps * self.dt_s
        positions_deg, supply_v = np.degrees(self._trace_rad[rows]), self._trace_v[rows]
        kept = zip(times_s, positions_deg, supply_v)
        return [TraceStep(float(t), p, float(v)) for t, p, v in kept]

    def _make_room(self, steps: int) -> None:
        """Rows in the trace's ring for ``steps`` steps (twice as many as before at a time)."""
        rows = len(self._trace_v)
        if rows >= min(steps, TRACE_LIMIT):
            return
        more = min(max(2 * rows, steps, 1024), TRACE_LIMIT) - rows
        self._trace_rad = np.concatenate((self._trace_rad, np.empty((more, len(self._zero)))))
        self._trace_v = np.concatenate((self._trace_v, np.empty(more)))

    def _edges_ahead(self, end: int) -> tuple[np.ndarray, np.ndarray]:
        """The servos' play edges (``ServoDrive.play_edges``) at each step from the next one to
        ``end`` (steps, joints), from those worked out ahead: at least ``STEPS_AHEAD`` steps'
        set-points at a time, and their edges with them (a bus read every 2 ms asks for one
        step at a time, whose set-points and edges cost two dozen numpy calls each)."""
        first = self._steps - self._ahead_from
        if first < 0 or end - self._ahead_from > len(self._ahead_low):
            self._stop_ahead()
            self._ahead_from, first = self._steps, 0
            setpoints = self._setpoints_rad(self._steps, max(end, self._steps + STEPS_AHEAD))
            self._ahead_low, self._ahead_high, self._ahead_line = self._drive.edges_ahead(setpoints)
        rows = slice(first, first + end - self._steps)
        return self._ahead_low[rows], self._ahead_high[rows]

    def _stop_ahead(self) -> None:
        """The servos' delay line moved on to the step reached, the edges worked out ahead of
        it dropped (a servo driven anew, or all of them used)."""
        if self._ahead_line is not None:
            self._drive.move_on(self._ahead_line, self._steps - self._ahead_from)
            self._ahead_line = None
        self._ahead_low = self._ahead_high = self._ahead_low[:0]

    def _setpoints_rad(self, start: int, end: int) -> np.ndarray:
        """Every servo's set-point at each step from ``start`` to ``end`` (steps, joints):
        nothing drives the servos in between, so at once rather than one step at a time."""
        now = self._origin_s + np.arange(start, end)[:, None] * self.dt_s
        moving = np.maximum(np.minimum(now, self._end_s) - self._start_s, 0.0)
        setpoint_units = self._start_units + self._velocity * moving
        return np.radians((setpoint_units - self._zero) * self._direction * DEG_PER_UNIT)

    def _step_physics(self, low_rad: np.ndarray, high_rad: np.ndarray) -> None:
        """One physics step, the servos' aims kept within ``ServoDrive.play_edges``."""
        model, data, actuators = self._model, self._data, self._actuator_at
        position = data.qpos[self._joint_qpos]
        ctrl = self._drive.follow(low_rad, high_rad, position, out=self._ctrl)
        if self._any_unloaded:
            np.copyto(ctrl, position, where=self._unloaded)  # unloaded: no torque
        data.ctrl[actuators] = ctrl
        sag = self._supply_now_v / self.supply_v if self.supply_v else 1.0
        if abs(sag - self._sag) > SAG_STEP:
            self._set_sag(sag)
        mujoco.mj_step(model, data)
        load = np.abs(data.actuator_force[actuators], out=self._load)
        load *= self._per_stall  # each servo's torque as a share of its stall torque
        current_a = self._idle_a + STALL_CURRENT_A * float(np.dot(load, self._loaded_share))
        self._supply_now_v = max(0.0, self.supply_v - self.resistance_ohm * current_a)
        # towards RISE_AT_STALL_C * load² above the ambient, by dt / THERMAL_TIME_S of the way
        heat = np.multiply(load, self._rise_c, out=self._heat)
        heat *= load
        heat -= np.subtract(self._temp_c, self._ambient_c, out=self._cooling)
        heat *= self._per_step_of_thermal_time
        self._temp_c += heat

    def _set_sag(self, sag: float) -> None:
        """The servos' torque and gain at a supply ``sag`` times the nominal one."""
        model, actuators = self._model, self._index.actuator
        model.actuator_forcerange[actuators, 0] = -self._stall_nm * sag
        model.actuator_forcerange[actuators, 1] = self._stall_nm * sag
        model.actuator_gainprm[actuators, 0] = self._kp * sag
        model.actuator_biasprm[actuators, 1] = -self._kp * sag
        self._sag = sag
        self._per_stall = 1 / np.maximum(self._stall_nm * sag, 1e-9)


@dataclass(frozen=True)
class _ServoInWorld:
    """One servo's view of the world (``choreo.emulator.physics.ServoPhysics``)."""

    twin: PhysicsTwin
    joint: int

    def drive(self, time_s: float, setpoint: SetPoint, loaded: bool) -> None:
        self.twin.drive(self.joint, time_s, setpoint, loaded)

    def output_units(self, time_s: float) -> float:
        return self.twin.output_units(self.joint, time_s)

    def vin_mv(self, time_s: float) -> int:
        return round(self.twin.supply_at(time_s) * 1000)

    def temp_c(self, time_s: float) -> float:
        return self.twin.temp_at(self.joint, time_s)


def _on_a_stand(robot: Robot) -> mujoco.MjModel:
    """A free-floating robot's model with its body fixed ``STAND_LIFT_M`` above where the MJCF
    puts it (its free joint and keyframes removed), its legs free in the air."""
    path = robot.scene_path or robot.mjcf_path
    spec = mujoco.MjSpec.from_file(str(path))
    for joint in [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]:
        body = joint.parent
        spec.delete(joint)
        body.pos = np.asarray(body.pos) + np.array([0.0, 0.0, STAND_LIFT_M])
        # fixed, the body is part of the world, and MuJoCo filters no contact between the world
        # and its children: without this a coxa touching the body is pushed to its limit
        for child in body.bodies:
            spec.add_exclude(bodyname1=body.name, bodyname2=child.name)
    for key in list(spec.keys):  # their qpos still has the free joint's seven numbers
        spec.delete(key)
    return spec.compile()


def physics_for(
    robot: str | Path, truth: str | Path | None, clock: Clock, *, stand: bool = False
) -> PhysicsTwin:
    """The world ``sim://?physics=ROBOT&truth=FILE&stand=1`` names: the robot (a name or its
    robot.yaml) with the servos of the truth file, else of the robot file; ``stand``: a
    free-floating robot's body held in the air, as on a stand."""
    loaded = load_robot(robot)
    figures = read_servo_figures(truth, loaded) if truth else None
    return PhysicsTwin(loaded, figures, clock, stand=stand)
