"""The ranges and checks every public argument goes through: what is in, and the one message for
what is not (tests/test_api_arguments.py walks them through the whole public API)."""

from __future__ import annotations

import enum
import math

import pytest

from choreo.core.arguments import (
    COUNT,
    POSITIVE,
    Range,
    check_member,
    check_number,
    check_optional_number,
    check_path,
)
from choreo.errors import OptionError


@pytest.mark.parametrize("value", [1, 0.001, 1e300])
def test_a_positive_number_is_in(value):
    assert value in POSITIVE and check_number("speed", value, POSITIVE) == value


@pytest.mark.parametrize("value", [0, -1, math.nan, math.inf, -math.inf, True, "1", None, 10**400])
def test_what_is_no_positive_number_is_out(value):
    assert value not in POSITIVE


def test_a_count_is_a_whole_number_from_one_however_large():
    assert COUNT.number(10**400) == 10**400
    assert 2.0 not in COUNT and 0 not in COUNT


def test_the_message_names_the_option_the_bounds_the_unit_and_the_value():
    limit = Range(above=0, at_most=5, unit="°")
    assert str(limit) == "a number > 0 and <= 5°"
    with pytest.raises(OptionError) as refused:
        check_number("tolerance_deg", 6, limit)
    assert refused.value.option == "tolerance_deg"
    assert str(refused.value) == "tolerance_deg must be a number > 0 and <= 5°, got 6"


def test_a_range_in_another_unit_keeps_its_bounds():
    assert str(Range(at_least=0, at_most=2).scaled(1000, " ms")) == "a number >= 0 and <= 2000 ms"


def test_a_range_has_one_lower_bound():
    with pytest.raises(ValueError, match="one lower bound"):
        Range(above=0, at_least=1)


def test_none_is_the_default_of_an_optional_number_and_said_so_when_refused():
    assert check_optional_number("seed", None) is None
    with pytest.raises(OptionError, match=r"seed must be a number, or None, got 'x'"):
        check_optional_number("seed", "x")


class Colour(enum.Enum):
    RED = "red"


def test_an_enum_member_is_given_as_itself_or_by_its_value():
    assert check_member("colour", "red", Colour) is Colour.RED
    assert check_member("colour", Colour.RED, Colour) is Colour.RED
    with pytest.raises(OptionError) as refused:
        check_member("colour", "blue", Colour)
    assert refused.value.option == "colour" and "red" in str(refused.value)


def test_a_path_is_a_string_or_a_path_like_and_nothing_else(tmp_path):
    assert check_path("song", str(tmp_path)) == tmp_path
    with pytest.raises(OptionError, match="song must be a path"):
        check_path("song", 3)
