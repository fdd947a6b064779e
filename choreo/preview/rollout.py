"""What a simulation recorded (``Rollout``), step by step: the joints, the servos' set-points and
torques, the touches worth reporting (``Contacts``), a free-floating robot's body (``FreeBody``)
and how it settled before the approach. ``sim.simulate`` makes one; nothing here judges it."""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from choreo.motion.scene import Prop, StartPosture
from choreo.preview.actuator import ActuatorParams
from choreo.robot.types import Robot


class MoveStart(str, Enum):
    """Where a servo's new linear move starts (undocumented for the real servo).

    SETPOINT: where its own interpolation is, so a servo lagging under load keeps pulling towards
    its plan (what a position loop with integral action amounts to). POSITION: where its shaft
    measurably is, so each START forgets the lag; with a proportional-only servo model a loaded
    joint then drops a little at every START, and a re-run preset from a sagged position creeps
    back over the preset's whole time: the pessimistic assumption.
    """

    SETPOINT = "setpoint"
    POSITION = "position"


if TYPE_CHECKING:
    from choreo.preview.step_loop import Resume


@dataclass(frozen=True)
class ContactPair:
    """Two things touching that may not: ``kind`` is "self" (two links that are not parent and
    child), "neighbour" (a parent and child link MuJoCo lets collide), "floor" (a fixed robot's
    link on a world geom, named ``body_b``), "ground" (a free-floating robot's link other than
    a foot on the floor or a fixed prop, named ``body_b``), "foot" (a foot there), or "held" (a
    link on a free prop: expected, recorded to say what a straining servo pushes on)."""

    kind: str
    body_a: str
    body_b: str


@dataclass(frozen=True)
class Settling:
    """The start pose held until still, before the approach: how far the body dropped and
    tilted doing so (a free-floating robot's root body; zeros for a fixed robot)."""

    duration_s: float
    drop_m: float
    tilt_deg: float
    still: bool  # False: still moving after SimSettings.max_settle_s


@dataclass(frozen=True)
class Contacts:
    """The touches worth reporting, one entry per physics step and pair touching: the step, the
    pair (an index into ``pairs``) and how deep."""

    pairs: tuple[ContactPair, ...]
    step: np.ndarray  # (k,) step index of each recorded contact
    pair: np.ndarray  # (k,) index into pairs
    depth_m: np.ndarray  # (k,) penetration depth

    def mask(self, pair_index: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Per step of ``steps``: whether the pair touches, and how deep (m)."""
        mine = self.pair == pair_index
        touching = np.zeros(steps, dtype=bool)
        touching[self.step[mine]] = True
        depth = np.zeros(steps)
        np.maximum.at(depth, self.step[mine], self.depth_m[mine])
        return touching, depth

    def since(self, k: int) -> Contacts:
        """The contacts from step ``k`` on, their steps counted from there."""
        keep = self.step >= k
        return Contacts(self.pairs, self.step[keep] - k, self.pair[keep], self.depth_m[keep])


@dataclass(frozen=True)
class FreeBody:
    """A free-floating robot's root body (the one carrying the free joint), step by step."""

    name: str
    qpos_address: int  # where its position and quaternion start in qpos
    height_m: np.ndarray  # (n,)
    tilt_deg: np.ndarray  # (n,) angle between its z axis and the vertical
    feet: tuple[str, ...] = ()  # the robot's foot links: what may touch the ground

    def since(self, k: int) -> FreeBody:
        return replace(self, height_m=self.height_m[k:], tilt_deg=self.tilt_deg[k:])


@dataclass(frozen=True)
class Rollout:
    """What the simulation recorded, sampled at every physics step. Times count from the
    motion's start: negative ones are the settling, then the approach (from
    ``approach_start_s``)."""

    robot: Robot
    times_s: np.ndarray  # (n,)
    position_deg: np.ndarray  # (n, joints) the joints' real angles
    setpoint_deg: np.ndarray  # (n, joints) where each servo's own interpolation is
    command_deg: np.ndarray  # (n, joints) the path the ticks ask for (no load, no lag)
    torque_nm: np.ndarray  # (n, joints) actuator torque
    qpos: np.ndarray  # (n, nq) full MuJoCo state, for rendering
    actuators: tuple[ActuatorParams, ...]
    contacts: Contacts
    commands_end_s: float  # when the last commanded move is due to finish
    keyframe_times_s: tuple[float, ...] = ()
    body: FreeBody | None = None  # a free-floating robot's root body; None: fixed to the world
    approach_start_s: float = 0.0  # <= 0: when the approach into the first pose begins
    settling: Settling | None = None
    posture: StartPosture = StartPosture.STANDING
    props: tuple[Prop, ...] = ()
    move_start: MoveStart = MoveStart.SETPOINT
    joint_links: tuple[str, ...] = ()  # the link each joint moves (robot joint order)
    # each free prop's name and where its position and quaternion start in qpos
    prop_qpos_addresses: tuple[tuple[str, int], ...] = ()
    resume: Resume | None = None  # to simulate a tick list that begins the same way faster

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def start_step(self) -> int:
        """The first step of the approach: the robot at rest in its start pose."""
        return int(np.searchsorted(self.times_s, self.approach_start_s - 1e-9))

    @property
    def stall_torque_nm(self) -> np.ndarray:
        return np.array([a.stall_torque_nm for a in self.actuators])

    def since_start(self) -> Rollout:
        """The rollout from the start (the robot at rest before the approach): what the checks
        judge; the settling before it is the simulation finding its feet, reported apart."""
        k = self.start_step
        return replace(
            self,
            times_s=self.times_s[k:],
            position_deg=self.position_deg[k:],
            setpoint_deg=self.setpoint_deg[k:],
            command_deg=self.command_deg[k:],
            torque_nm=self.torque_nm[k:],
            qpos=self.qpos[k:],
            contacts=self.contacts.since(k),
            body=None if self.body is None else self.body.since(k),
        )

    def phase(self, t: float) -> str:
        """ "settling", "approach" or "motion" at time ``t``."""
        if t < self.approach_start_s - 1e-9:
            return "settling"
        return "approach" if t < -1e-9 else "motion"
