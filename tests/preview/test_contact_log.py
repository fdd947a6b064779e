"""The touches a simulation logs: a collision caught naming the bodies, within a tick of when
MuJoCo's own collision detection along the plan finds it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from preview_helpers import MOTIONS, tick_at

from choreo.motion.motion_file import load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import compile_ticks
from choreo.preview import (
    CheckKind,
    Severity,
    run_checks,
    simulate_motion,
)


# --- the checks --------------------------------------------------------------------------------
def first_touch_s(robot, trajectory, bodies: set[str]) -> float:
    """When the planned trajectory first brings ``bodies`` into contact: MuJoCo's collision
    detection along the plan, independent of the preview."""
    model = mujoco.MjModel.from_xml_path(str(robot.scene_path))
    data = mujoco.MjData(model)
    address = [model.joint(j.mjcf_joint).qposadr[0] for j in robot.joints]
    times = np.arange(0.0, trajectory.duration_s, 0.002)
    for t, angles in zip(times, trajectory.positions(times)):
        data.qpos[address] = np.radians(angles)
        mujoco.mj_forward(model, data)
        for contact in data.contact[: data.ncon]:
            touching = {model.body(model.geom_bodyid[g]).name for g in contact.geom}
            if touching == bodies:
                return float(t)
    raise AssertionError(f"the plan never brings {bodies} together")


@pytest.mark.parametrize(
    "name, kind, bodies, touching",
    [
        ("collide.yaml", CheckKind.SELF_COLLISION, ("base", "forearm"), {"base", "forearm"}),
        ("floor.yaml", CheckKind.FLOOR_CONTACT, ("forearm", "floor"), {"forearm", "world"}),
    ],
)
def test_a_collision_is_caught_naming_the_bodies_within_a_tick(name, kind, bodies, touching):
    motion = load_motion(MOTIONS / name)
    trajectory = plan_motion(motion).trajectory
    ticks = compile_ticks(trajectory, motion.robot).ticks
    expected_s = first_touch_s(motion.robot, trajectory, touching)
    results = run_checks(simulate_motion(motion))
    found = [r for r in results if r.kind is kind]
    assert found, results
    assert found[0].bodies == bodies and found[0].severity is Severity.ERROR
    assert abs(found[0].time_s - expected_s) <= tick_at(ticks, expected_s).duration_ms / 1000
    assert bodies[0] in found[0].message and f"t={found[0].time_s:.2f} s" in found[0].message
