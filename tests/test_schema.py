"""The JSON Schemas shipped for editors agree with the loader and with the files we ship."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
import yaml
from paths import DATA, REPO

from choreo.bus.protocol import MAX_SERVO_ID
from choreo.bus.servo_bus import EchoMode
from choreo.bus.servo_models import ACTUATOR_FIELDS, POSITION_RANGE_UNITS, SERVO_MODELS
from choreo.core.file_shape import Shape, mapping_shape
from choreo.motion import keyframe_entry, keyframe_list
from choreo.motion.scene import PROP_BOUNDS
from choreo.motion.timing import MAX_SPEED, MAX_TIME_S, MIN_SPEED
from choreo.robot import bus_entry, joint_entry, servo_figures
from choreo.robot import robot_file as robot


def schema(name: str) -> dict:
    text = (resources.files("choreo") / "schema" / f"{name}.schema.json").read_text()
    return json.loads(text)


def validator(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(schema(name))


def errors(name: str, path: Path) -> list[str]:
    document = yaml.safe_load(path.read_text())
    return [error.message for error in validator(name).iter_errors(document)]


@pytest.mark.parametrize("name", ["motion", "robot"])
def test_schemas_are_valid_draft_2020_12(name):
    assert schema(name)["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema(name))


def test_the_loaders_take_their_keys_from_the_schemas():
    """The keys as docs/motion-format.md lists them: own keys first, then the shared timing."""
    assert keyframe_list.MOTION == mapping_shape("motion")
    assert keyframe_list.MOTION.keys == (
        "name", "description", "robot", "speed", "repeat", "start", "end", "props", "music",
        "keyframes",
    )  # fmt: skip
    assert keyframe_list.MOTION.required == ("robot", "keyframes")
    assert keyframe_entry.KEYFRAME == Shape(
        ("pose", "sites", "body", "hold", "stop", "velocity", "t", "after", "beat", "bar"), ()
    )
    assert keyframe_entry.GAIT == Shape(("gait",), ("gait",))
    assert keyframe_list.INCLUDE == Shape(
        ("include", "mirror", "t", "after", "beat", "bar"), ("include",)
    )
    assert robot.ROBOT.keys == (
        "name", "mjcf", "scene", "servo_figures", "bus", "defaults", "joints", "poses", "mirror",
        "gait",
    )  # fmt: skip
    assert robot.ROBOT.required == ("name", "joints", "poses")
    assert joint_entry.JOINT.keys == ("id", *robot.DEFAULTS.keys)
    assert joint_entry.JOINT.required == ("id",)
    assert bus_entry.BUS == Shape(
        ("port", "timeout_ms", "retries", "echo", "supply_v", "direction"), ()
    )
    assert bus_entry.ECHO_MODES == tuple(mode.value for mode in EchoMode)
    assert robot.MIRROR_PAIR == Shape(("left", "right", "sign"), ("left", "right", "sign"))
    assert servo_figures.GAIT == Shape(tuple(servo_figures.GAIT_BOUNDS), ())  # robot's gait:
    assert set(joint_entry.REQUIRED_JOINT_KEYS) <= set(joint_entry.JOINT.keys)


def test_the_preview_knows_every_actuator_key_of_the_schema():
    assert joint_entry.ACTUATOR.keys == ACTUATOR_FIELDS


def test_the_ranges_the_robot_schema_repeats_are_the_codes():
    settings = schema("robot")["$defs"]["jointSettings"]["properties"]
    joint = schema("robot")["properties"]["joints"]["additionalProperties"]
    assert joint["properties"]["id"]["maximum"] == MAX_SERVO_ID
    zero = settings["zero"]
    assert (zero["minimum"], zero["maximum"]) == POSITION_RANGE_UNITS


def test_the_gait_ranges_the_robot_schema_repeats_are_the_codes():
    gait = schema("robot")["properties"]["gait"]["properties"]
    bounds = servo_figures.GAIT_BOUNDS  # a robot file's gait: and a servo figures file's
    assert {key: (v["minimum"], v["maximum"]) for key, v in gait.items()} == bounds


def test_the_time_bound_the_motion_schema_repeats_is_the_codes():
    definitions = schema("motion")["$defs"]
    assert definitions["seconds"]["maximum"] == MAX_TIME_S
    assert definitions["gaitBlock"]["properties"]["gait"]["properties"]["period"]["maximum"] == (
        MAX_TIME_S
    )


def test_the_speed_range_the_motion_schema_repeats_is_the_codes():
    speed = schema("motion")["properties"]["speed"]
    assert (speed["minimum"], speed["maximum"]) == (MIN_SPEED, MAX_SPEED)


def test_the_velocity_minimum_the_motion_schema_repeats_is_the_codes():
    velocity = schema("motion")["$defs"]["poseKeyframe"]["properties"]["velocity"]
    assert (velocity["minimum"], velocity["maximum"]) == (keyframe_entry.MIN_VELOCITY_SCALE, 1)


def test_the_prop_ranges_the_motion_schema_repeats_are_the_codes():
    fields = schema("motion")["properties"]["props"]["items"]["properties"]
    for key, bounds in PROP_BOUNDS.items():
        field = fields[key].get("items", fields[key])  # a vector's bounds are its items'
        low = field["exclusiveMinimum" if bounds.get("low_open") else "minimum"]
        assert (low, field["maximum"]) == (bounds["low"], bounds["high"]), key


def test_a_pointer_to_no_mapping_is_refused():
    with pytest.raises(ValueError, match="describes no mapping"):
        mapping_shape("motion", "#/$defs/seconds")


def test_servo_models_in_the_schema_are_the_servo_table():
    servo = schema("robot")["$defs"]["jointSettings"]["properties"]["servo"]
    assert servo["enum"] == list(SERVO_MODELS)


GOOD_MOTIONS = sorted((REPO / "motions").glob("*/*.yaml")) + sorted(
    (DATA / "motions").glob("*.yaml")
)
GOOD_ROBOTS = sorted((REPO / "models").glob("*/robot.yaml")) + [DATA / "models/tiny/robot.yaml"]


def test_there_are_shipped_motions_to_check():
    assert any(path.is_relative_to(REPO / "motions") for path in GOOD_MOTIONS)


@pytest.mark.parametrize("path", GOOD_MOTIONS, ids=lambda p: p.name)
def test_schema_accepts_good_motions(path):
    assert errors("motion", path) == []


@pytest.mark.parametrize("path", GOOD_ROBOTS, ids=lambda p: p.parent.name)
def test_schema_accepts_good_robots(path):
    assert errors("robot", path) == []


# The mistakes of shape; the others (unknown joints, limits, timing, includes, the MJCF) need the
# robot and are for `choreo validate`.
@pytest.mark.parametrize(
    "name, words",
    [
        ("unknown_key.yaml", "'hodl' was unexpected"),
        ("t_and_after.yaml", "should not be valid under {'required': ['t', 'after']}"),
        ("wrong_type.yaml", "'soon' is not of type 'number'"),
        ("several_problems.yaml", "0 is less than the minimum of 0.01"),
        ("empty.yaml", "None is not of type 'object'"),
    ],
)
def test_schema_rejects_bad_motions(name, words):
    assert any(words in message for message in errors("motion", DATA / "bad_motions" / name))


@pytest.mark.parametrize(
    "case, words",
    [
        ("missing_home", "'home' is a required property"),
        ("unknown_servo", "'LX16A' is not one of"),
        ("several_problems", "'discrad' is not one of"),
    ],
)
def test_schema_rejects_bad_robots(case, words):
    path = DATA / "bad_robots" / case / "robot.yaml"
    assert any(words in message for message in errors("robot", path))


def test_schema_rejects_an_include_entry_with_keyframe_options():
    document = {"robot": "tiny", "keyframes": [{"include": "part.yaml", "hold": 1.0}]}
    messages = [e.message for e in validator("motion").iter_errors(document)]
    assert any("'hold' was unexpected" in message for message in messages)
