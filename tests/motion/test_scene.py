"""The scene a motion file sets: how the robot starts and the props it works with, read at their
lines."""

from __future__ import annotations

import paths
import pytest

from choreo.errors import SourceError
from choreo.motion.motion_file import load_motion
from choreo.motion.scene import Prop, StartPosture
from choreo.preview.model import load_model


def test_props_are_read_from_the_motion_file_and_bad_ones_refused(tmp_path):
    good = tmp_path / "good.yaml"
    robot = (paths.DATA / "preview" / "models" / "arm3" / "robot.yaml").as_posix()
    good.write_text(
        f"robot: {robot}\nstart: lying_back\nprops:\n"
        "  - {name: step, size_m: [0.3, 0.4, 0.02], at_m: [0.2, 0, 0], yaw_deg: 10}\n"
        "keyframes:\n  - pose: home\n"
    )
    motion = load_motion(good)
    assert motion.start is StartPosture.LYING_BACK
    assert motion.props == (Prop("step", (0.3, 0.4, 0.02), (0.2, 0.0, 0.0), 10.0),)
    model = load_model(motion.robot, motion.props)
    step = model.geom("step")
    assert step.size == pytest.approx([0.15, 0.2, 0.01]) and step.pos[2] == pytest.approx(0.01)
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        f"robot: {robot}\nstart: sitting\nprops:\n"
        "  - {name: step, size_m: [0.3, -1, 0.02], at_m: [0.2, 0]}\n"
        "keyframes:\n  - pose: home\n"
    )
    with pytest.raises(SourceError) as error:
        load_motion(bad)
    text = str(error.value)
    assert "bad.yaml:2:8: start 'sitting' is not one of standing, lying" in text
    assert "props[0]: size_m must be in (0, 10] m, got -1" in text
    assert "props[0]: at_m needs three numbers" in text


def test_free_prop_fields_are_read_and_bad_ones_refused(tmp_path):
    robot = (paths.DATA / "preview" / "models" / "arm3" / "robot.yaml").as_posix()
    good = tmp_path / "good.yaml"
    good.write_text(
        f"robot: {robot}\nprops:\n"
        "  - {name: cup, size_m: [0.05, 0.05, 0.08], at_m: [0.2, 0, 0], mass_kg: 0.1,\n"
        "     friction: 0.8, place_at_m: [0.1, 0.1, 0]}\n"
        "keyframes:\n  - pose: home\n"
    )
    (cup,) = load_motion(good).props
    assert cup == Prop("cup", (0.05, 0.05, 0.08), (0.2, 0, 0), 0.0, 0.1, 0.8, (0.1, 0.1, 0))
    assert cup.free
    for line, text in (
        ("{name: b, size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], mass_kg: 0}", "mass_kg"),
        ("{name: b, size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], friction: 1}", "needs mass_kg"),
        ("{name: b, size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], place_at_m: [0, 0]}", "place_at_m"),
    ):
        bad = tmp_path / "bad.yaml"
        bad.write_text(f"robot: {robot}\nprops:\n  - {line}\nkeyframes:\n  - pose: home\n")
        with pytest.raises(SourceError, match=rf"bad.yaml:3.*{text}"):
            load_motion(bad)


@pytest.mark.parametrize(
    "fields, where, message",
    [
        ("size_m: [1.0e+308, 0.1, 0.1], at_m: [0, 0, 0]", "3:24", "size_m must be in (0, 10] m"),
        ("size_m: [0.1, 0.1, 0.1], at_m: [0, 1.0e+308, 0]", "3:50", "at_m must be in -10..10 m"),
        (
            "size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], yaw_deg: 1.0e+308",
            "3:66",
            "yaw_deg must be in -180..180°",
        ),
        (
            "size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], mass_kg: 1.0e+308",
            "3:66",
            "mass_kg must be in (0, 1000] kg",
        ),
        (
            "size_m: [0.1, 0.1, 0.1], at_m: [0, 0, 0], mass_kg: 1, friction: 1.0e+308",
            "3:79",
            "friction must be in (0, 10]",
        ),
    ],
)
def test_absurd_prop_numbers_are_refused_at_their_line_with_the_range(
    tmp_path, fields, where, message
):
    """1e308 reached MuJoCo, which printed a warning every simulation step."""
    path = tmp_path / "m.yaml"
    path.write_text(f"robot: arm6\nprops:\n  - {{name: b, {fields}}}\nkeyframes:\n  - pose: home\n")
    with pytest.raises(SourceError) as raised:
        load_motion(path)
    assert raised.value.problems == [f"{path}:{where}: props[0]: {message}, got 1e+308"]
