"""Names that become a chunk of a Zenoh key: performers', realms'."""

import pytest

from choreo.errors import OptionError
from choreo.show.names import check_name, is_name, name_from


@pytest.mark.parametrize("name", ["tony", "arm-2", "A_b-9"])
def test_ascii_letters_digits_dash_and_underscore_make_a_name(name):
    assert is_name(name) and check_name("realm", name) == name


@pytest.mark.parametrize("name", ["ünï", "tony 1", "a/b", "*", "a$", "", "٣"])
def test_anything_else_is_one_line_naming_the_argument_and_the_rule(name):
    with pytest.raises(OptionError) as raised:
        check_name("realm", name)
    assert raised.value.option == "realm"
    assert (
        raised.value.problem == f"{name!r} is not a name: use only ASCII letters, digits, - and _"
    )


def test_a_host_name_is_made_a_name():
    assert name_from("pi.local") == "pi-local"
    assert name_from("ünï") == "-n-"
    assert name_from("") == "performer"
