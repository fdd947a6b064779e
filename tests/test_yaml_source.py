"""Reading numbers from YAML nodes: every float the YAML 1.1 spec (PyYAML's resolver) allows is
read as PyYAML reads it, and what is no finite number is refused with its place."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from choreo.core.yaml_source import Problems, Reader

# Floats as the YAML 1.1 spec writes them (yaml.org/type/float.html), with their values there.
SPEC_FLOATS = {
    "6.8523015e+5": 685230.15,
    "685.230_15e+03": 685230.15,
    "685_230.15": 685230.15,
    "190:20:30.15": 685230.15,  # base 60
    "-0.5": -0.5,
    "+12.": 12.0,
    "!!float 3": 3.0,
}


def read_number(text: str, problems: Problems) -> float | None:
    node = yaml.compose(f"x: {text}\n", Loader=yaml.SafeLoader).value[0][1]
    return Reader(Path("f.yaml"), problems).number(node, "x")


@pytest.mark.parametrize("text", SPEC_FLOATS)
def test_the_specs_floats_are_read_at_their_value(text):
    problems = Problems()
    assert read_number(text, problems) == pytest.approx(SPEC_FLOATS[text], abs=0, rel=1e-15)
    assert not problems


def test_negative_zero_keeps_its_sign():
    assert math.copysign(1, read_number("-0.0", Problems())) == -1


@pytest.mark.parametrize("text", [".inf", "-.inf", ".nan"])
def test_what_is_no_finite_number_is_refused_where_it_is(text):
    problems = Problems()
    assert read_number(text, problems) is None
    assert problems.messages == [f"f.yaml:1:4: x must be a number, got {text}"]
