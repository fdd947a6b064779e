"""choreo.core.file_shape: the keys of each mapping come from the JSON Schemas shipped for
editors. The expected keys are read here straight from the schema files (the golden source the
editors use), not through the module under test."""

from __future__ import annotations

import json

import pytest
from paths import REPO

from choreo.core.file_shape import Shape, choices, mapping_shape

SCHEMAS = REPO / "choreo" / "schema"


def schema(name: str) -> dict:
    return json.loads((SCHEMAS / f"{name}.schema.json").read_text())


@pytest.mark.parametrize("name", ["motion", "robot"])
def test_the_top_level_keys_are_the_schemas_in_its_order(name):
    whole = schema(name)
    assert mapping_shape(name) == Shape(
        tuple(whole["properties"]), tuple(whole.get("required", ()))
    )


def test_a_definition_that_refers_to_another_gets_its_keys_too():
    """A pose keyframe's own keys, then the timing keys its $ref brings (t, after, beat, bar)."""
    definitions = schema("motion")["$defs"]
    pose = definitions["poseKeyframe"]
    assert pose["$ref"] == "#/$defs/timing"
    shape = mapping_shape("motion", "#/$defs/poseKeyframe")
    assert shape.keys == (*pose["properties"], *definitions["timing"]["properties"])
    assert set(definitions["timing"]["properties"]) == {"t", "after", "beat", "bar"}


def test_required_keys_are_collected_along_the_reference():
    include = schema("motion")["$defs"]["includeEntry"]
    shape = mapping_shape("motion", "#/$defs/includeEntry")
    assert shape.required == tuple(include["required"]) == ("include",)
    assert "after" in shape.keys  # from the timing it refers to


def test_a_pointer_to_something_without_keys_is_an_error_naming_it():
    with pytest.raises(ValueError, match=r"motion\.schema\.json#/\$defs/seconds describes no"):
        mapping_shape("motion", "#/$defs/seconds")


def test_choices_are_the_enum_at_the_pointer():
    echo = schema("robot")["properties"]["bus"]["properties"]["echo"]
    assert choices("robot", "#/properties/bus/properties/echo") == tuple(echo["enum"])
    assert "auto" in echo["enum"]


def test_the_robot_loader_takes_its_echo_modes_from_the_schema():
    from choreo.robot.bus_entry import ECHO_MODES

    assert ECHO_MODES == tuple(schema("robot")["properties"]["bus"]["properties"]["echo"]["enum"])
