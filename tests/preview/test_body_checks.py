"""How a robot that means to end lying comes down: a controlled lie-down passes, a topple onto
the floor is a fall, whatever the ``end:`` says."""

from __future__ import annotations

import pytest
from paths import DATA, REPO

from choreo.preview import CheckKind, Severity, preview_report, run_checks, simulate_motion
from choreo.preview.impact import IMPACT_SPEED_M_S

MOTIONS = DATA / "preview" / "motions"


def test_a_tonypi_toppling_onto_its_face_in_its_last_move_is_a_fall():
    """Declared ``end: lying_front``, its last move bends it at the hips with straight legs: it
    topples and its torso hits the floor at ~1.5 m/s (before: 0 errors, 0 warnings)."""
    simulated = simulate_motion(MOTIONS / "topple_declared.yaml")
    results = run_checks(simulated)
    (fall,) = [r for r in results if r.kind is CheckKind.FALL]
    assert fall.severity is Severity.ERROR
    assert fall.bodies == ("torso", "floor")
    assert fall.value == pytest.approx(1.5, abs=0.3)
    assert "torso hits the floor first" in fall.message
    assert fall.time_s > simulated.lie_down_from_s  # in the declared lie-down, not before it
    report = preview_report(simulated, results)
    assert report["impacts"][0]["link"] == "torso"
    assert report["impacts"][0]["speed_m_s"] == pytest.approx(fall.value, abs=0.001)


def test_a_hexapod_lowered_onto_its_belly_as_declared_comes_down_gently():
    simulated = simulate_motion(MOTIONS / "lie_down_declared.yaml")
    assert run_checks(simulated) == []
    (touch,) = simulated.impacts
    assert touch.link == "torso" and touch.speed_m_s < IMPACT_SPEED_M_S / 5


def test_a_robot_declared_to_end_face_up_that_falls_on_its_face_is_reported(tmp_path):
    """The same topple declared ``end: lying_back``: where it ends is wrong as well."""
    text = (MOTIONS / "topple_declared.yaml").read_text()
    robot = (REPO / "models" / "tonypi" / "robot.yaml").as_posix()
    path = tmp_path / "topple_back.yaml"
    path.write_text(
        text.replace("end: lying_front", "end: lying_back").replace(
            "robot: ../../../../models/tonypi/robot.yaml", f"robot: {robot}"
        )
    )
    falls = [r for r in run_checks(simulate_motion(path)) if r.kind is CheckKind.FALL]
    assert [r.bodies[0] for r in falls] == ["torso", "torso"]
    assert "torso ends lying face down, not face up as its end: lying_back says" in (
        falls[1].message
    )
    assert falls[1].value > 90
