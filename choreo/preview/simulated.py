"""A motion simulated: what the simulation recorded (a ``Rollout``) with what was measured on it,
each its own frozen value: the body's travel, the free props' outcomes, a walker's stance and
gaits, the ``sites:`` targets reached. The checks, the report and the renderer read them here;
nothing is added to the rollout after the simulation.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from choreo.core.arguments import check_type
from choreo.motion.scene import StartPosture
from choreo.preview.impact import Impact
from choreo.preview.props import PropOutcome, prop_outcomes
from choreo.preview.reach import JointJump, SiteReach
from choreo.preview.rollout import Rollout
from choreo.preview.travel import BodyTravel, body_travel
from choreo.preview.walk import GaitOutcome, Walk, gait_outcomes


@dataclass(frozen=True)
class SimulatedMotion:
    """What ``simulate_motion`` returns: the ``rollout`` and what was measured against what the
    motion asked. Built with :meth:`of` (which measures the travel, props and gaits)."""

    rollout: Rollout
    end: StartPosture  # how the motion means to leave the robot
    walk: Walk | None  # a walker's plan, feet and centre of mass; None: not a walker
    site_reach: tuple[SiteReach, ...]  # each sites: target against where the site was
    joint_jumps: tuple[JointJump, ...]  # sites: keyframes IK met with a large joint move
    travel: BodyTravel | None  # where a free-floating robot's body went; None: fixed
    props: tuple[PropOutcome, ...]  # each free prop, from the start to the end
    gaits: tuple[GaitOutcome, ...]  # each gait: block, asked against done
    impacts: tuple[Impact, ...] = ()  # links coming down onto the ground (a motion ending lying)

    @classmethod
    def of(
        cls,
        rollout: Rollout,
        *,
        end: StartPosture = StartPosture.STANDING,
        walk: Walk | None = None,
        site_reach: tuple[SiteReach, ...] = (),
        joint_jumps: tuple[JointJump, ...] = (),
        impacts: tuple[Impact, ...] = (),
    ) -> SimulatedMotion:
        """``rollout`` with ``walk``, the ``sites:`` figures and the ``impacts`` measured by
        whoever knew the motion, and the travel, props and gaits measured here."""
        return cls(
            rollout,
            end,
            walk,
            site_reach,
            joint_jumps,
            body_travel(rollout),
            tuple(prop_outcomes(rollout)),
            tuple(gait_outcomes(rollout, walk)),
            impacts,
        )

    @property
    def lie_down_from_s(self) -> float | None:
        """A motion that ends lying lies down from its last keyframe but one on: from then on,
        the body low or on the floor is what it means to do (None: it ends standing)."""
        if not self.end.lying:
            return None
        times = self.rollout.keyframe_times_s
        return times[-2] if len(times) >= 2 else 0.0

    def since_start(self) -> SimulatedMotion:
        """From the start (the robot at rest before the approach), as ``Rollout.since_start``;
        what was measured stays as it was."""
        k = self.rollout.start_step
        return replace(
            self,
            rollout=self.rollout.since_start(),
            walk=None if self.walk is None else self.walk.since(k),
        )


EITHER = "a SimulatedMotion (from simulate_motion) or a Rollout (from simulate)"


def simulated_of(value: object, name: str = "rollout") -> SimulatedMotion:
    """``value`` as a ``SimulatedMotion``: a bare ``Rollout`` (no motion to measure it against)
    gets the travel, props and gaits only; anything else is refused."""
    if isinstance(value, Rollout):
        return SimulatedMotion.of(value)
    return check_type(name, value, SimulatedMotion, EITHER)


def rollout_of(value: object, name: str = "rollout") -> Rollout:
    """What the simulation recorded, of a ``SimulatedMotion`` or a bare ``Rollout``."""
    if isinstance(value, SimulatedMotion):
        return value.rollout
    return check_type(name, value, Rollout, EITHER)
