"""choreo.core.yaml_source: YAML read with file:line:column for every value, bounded in size, a
hint where YAML 1.1 reads a number as text, and numbers read as PyYAML reads them."""

from __future__ import annotations

import gc
import math
from pathlib import Path

import pytest
import yaml
from cli_helpers import error_line, motion_file

from choreo.cli import main
from choreo.core.yaml_source import (
    Problems,
    Reader,
    SourceLocation,
    parse_yaml_file,
    plain_number,
    quoted,
    shortened,
)
from choreo.errors import SourceError
from choreo.motion.motion_file import load_motion


@pytest.mark.parametrize(
    "written, hint", [("1e12", "1.0e+12"), ("2.5E3", "2.5e+3"), ("7.e2", "7.0e+2")]
)
def test_a_yaml_1_1_exponent_read_as_text_gets_a_hint(tmp_path, capsys, written, hint):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    after: {written}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:6:12: after must be a number in 0..86400 s, got {written!r} "
        f"(YAML reads {written} as text: write {hint})"
    )


def test_validate_reads_at_most_16_mib(tmp_path, capsys):
    huge = tmp_path / "video.yaml"
    with open(huge, "wb") as file:
        file.truncate(17 * 1024 * 1024)  # sparse: 17 MiB of zeros on no disk space
    assert main(["validate", str(huge)]) == 1
    assert capsys.readouterr().out == (
        f"{huge}:1:1: cannot read the file: it is larger than 16 MiB, the most a robot or "
        "motion file may be\n"
    )
    assert main(["validate", "/dev/zero"]) == 1  # a device is not read at all
    assert (
        capsys.readouterr().out
        == "/dev/zero:1:1: cannot read the file: it is a device, not a file\n"
    )


def read(tmp_path, text: str) -> tuple[Reader, yaml.Node]:
    path = tmp_path / "f.yaml"
    path.write_text(text)
    return Reader(path, Problems()), parse_yaml_file(path)


def test_every_refusal_says_file_line_column_and_what_is_valid(tmp_path):
    reader, root = read(tmp_path, "a: 1\nb:\n  c: -3\n  d: [x]\n")
    entries = {e.key: e for e in reader.entries(root, "the file")}
    inner = reader.fields(entries["b"].value, "b", allowed=("c", "d", "e"), required=("e",))
    assert reader.number(entries["a"].value, "a", low=0, high=1, low_open=True) == 1.0
    assert reader.integer(inner["c"].value, "c", low=0, high=9) is None
    assert reader.string(inner["d"].value, "d") is None
    path = tmp_path / "f.yaml"
    assert reader.problems.messages == [
        f"{path}:3:3: b is missing 'e' (required)",
        f"{path}:3:6: c must be in 0..9, got -3",
        f"{path}:4:6: d must be a text, got a list",
    ]


def test_an_unknown_key_gets_the_closest_valid_one(tmp_path):
    reader, root = read(tmp_path, "speeed: 2\n")
    assert reader.fields(root, "motion", allowed=("speed", "repeat")) == {}
    assert reader.problems.messages == [
        f"{tmp_path / 'f.yaml'}:1:1: unknown key 'speeed' in motion (did you mean 'speed'?); "
        "valid keys: speed, repeat"
    ]


def test_a_key_given_twice_is_reported_with_the_first_line(tmp_path):
    reader, root = read(tmp_path, "t: 1\nhold: 2\nt: 3\n")
    assert [e.key for e in reader.entries(root, "keyframe")] == ["t", "hold"]
    assert reader.problems.messages == [
        f"{tmp_path / 'f.yaml'}:3:1: keyframe: 't' is given twice (first at line 1); keep one"
    ]


@pytest.mark.parametrize(
    "text, words",
    [
        ("x: .inf", "1:4: x must be a number >= 0, got .inf"),
        ("x: true", "1:4: x must be a number >= 0, got true"),
        ("x:", "1:3: x must be a number >= 0, got nothing (null)"),
        ("x: -0.5", "1:4: x must be >= 0, got -0.5"),
    ],
)
def test_a_number_must_be_finite_and_in_range(tmp_path, text, words):
    reader, root = read(tmp_path, text + "\n")
    (entry,) = reader.entries(root, "file")
    assert reader.number(entry.value, "x", low=0) is None
    assert reader.problems.messages == [f"{tmp_path / 'f.yaml'}:{words}"]


def test_problems_are_sorted_by_file_then_place_and_said_once():
    problems = Problems()
    b, a = Path("b.yaml"), Path("a.yaml")
    problems.add(SourceLocation(b, 9, 1), "late")
    problems.add(SourceLocation(a, 2, 5), "other file")
    problems.add(SourceLocation(b, 3, 7), "early")
    problems.add(SourceLocation(b, 3, 7), "early")  # the same default read for every joint
    assert problems.messages == ["b.yaml:3:7: early", "b.yaml:9:1: late", "a.yaml:2:5: other file"]


def test_a_place_reached_through_includes_says_through_which():
    inner = SourceLocation(Path("part.yaml"), 4, 5)
    via = SourceLocation(
        Path("part.yaml"), 4, 5, included_at=(SourceLocation(Path("main.yaml"), 5, 14),)
    )
    assert str(via) == "part.yaml:4:5" and via == inner
    assert via.through == " (included at main.yaml:5:14)" and inner.through == ""


@pytest.mark.parametrize(
    "text, message",
    [
        ("a: [1, 2\n", "2:1: not valid YAML: "),  # then the parser's words (libyaml's or not)
        ("\xff\xfe", "1:1: cannot read the file: it is not UTF-8 text"),
    ],
)
def test_a_file_that_is_not_yaml_is_one_source_error(tmp_path, text, message):
    path = tmp_path / "f.yaml"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(SourceError) as raised:
        parse_yaml_file(path)
    assert str(raised.value).startswith(f"{path}:{message}")
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(
    "text, where, kind",
    [
        ("name: x\nrobot: arm6\x01\n", "2:12", "a control character (U+0001)"),
        ("name: x\ufffe\n", "1:8", "a character (U+FFFE)"),
    ],
)
def test_a_character_yaml_does_not_allow_is_pointed_at_in_one_line(tmp_path, text, where, kind):
    """PyYAML says where by the offset in the text, on a second line: choreo says line:col."""
    path = tmp_path / "f.yaml"
    path.write_text(text)
    with pytest.raises(SourceError) as raised:
        parse_yaml_file(path)
    assert str(raised.value) == (
        f"{path}:{where}: not valid YAML: {kind} YAML does not allow; remove it"
    )


def test_an_empty_file_is_no_document(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("# nothing yet\n")
    assert parse_yaml_file(path) is None


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


# Numbers as YAML 1.1 may write them: plain_number reads the plain ones as Reader.number does,
# and leaves the rest (None) to it, to be read in full and reported.
PLAIN_NUMBERS = ["0", "-0", "+5", "-35", "-12.5", "-0.0", "1.0e+12", "685_230.15", "!!float 3"]
OTHER_VALUES = [
    "012", "0x1F", "0b101", "1_000", "3:25", "190:20:30.15", ".inf", ".nan", "1.0e+999", "1e12",
    "!!float [1]", "'5'", "~", "true", "1" + "0" * 5000,
]  # fmt: skip


def yaml_value(text: str) -> yaml.Node:
    return yaml.compose(f"x: {text}\n", Loader=yaml.SafeLoader).value[0][1]


@pytest.mark.parametrize("text", PLAIN_NUMBERS)
def test_a_plain_number_is_read_quickly_as_the_reader_reads_it(text):
    problems = Problems()
    full = Reader(Path("f.yaml"), problems).number(yaml_value(text), "x")
    plain = plain_number(yaml_value(text))
    assert plain is not None and not problems
    assert (plain, math.copysign(1, plain)) == (full, math.copysign(1, full))


@pytest.mark.parametrize("text", OTHER_VALUES)
def test_any_other_value_is_left_to_the_reader(text):
    assert plain_number(yaml_value(text)) is None


def test_negative_zero_keeps_its_sign():
    assert math.copysign(1, read_number("-0.0", Problems())) == -1


@pytest.mark.parametrize("text", [".inf", "-.inf", ".nan"])
def test_what_is_no_finite_number_is_refused_where_it_is(text):
    problems = Problems()
    assert read_number(text, problems) is None
    assert problems.messages == [f"f.yaml:1:4: x must be a number, got {text}"]


def test_a_file_that_fails_to_load_leaves_the_collector_running(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("robot: arm6\nkeyframes: [\n")
    with pytest.raises(SourceError):
        load_motion(path)
    assert gc.isenabled()


def test_a_text_file_given_as_a_robot_is_quoted_by_no_more_than_its_first_line(tmp_path, capsys):
    """YAML reads the 40 lines as one text, joined by spaces: only the start of the first
    line is quoted, not the start of the second."""
    accounts = "".join(
        f"user{i}:x:{1000 + i}:{1000 + i}::/home/user{i}:/bin/sh\n" for i in range(40)
    )
    (tmp_path / "etc").mkdir()
    (tmp_path / "etc" / "passwd").write_text(accounts)
    path = tmp_path / "m.yaml"
    path.write_text("robot: etc/passwd\nkeyframes:\n  - pose: home\n")
    assert main(["validate", "--no-physics", str(path)]) == 1
    robot = tmp_path / "etc" / "passwd"
    assert capsys.readouterr().out.splitlines() == [
        f"{path}:1:8: robot {robot} has problems (listed after this line); fix them first",
        f"{robot}:1:1: the robot file must be a mapping (key: value lines), got a text over 40 "
        "lines starting 'user0:x:1000:1000::/home/user0:/bin/sh'…",
    ]


@pytest.mark.parametrize(
    "value, shown",
    [
        ("wave", "'wave'"),
        ("x" * 60, repr("x" * 60)),
        ("x" * 61, repr("x" * 60) + "…"),
        ("first line\nsecond line", "'first line'…"),
        (b"\x00" * 30, repr(b"\x00" * 30)[:60] + "…"),
        (12, "12"),
    ],
)
def test_a_value_is_quoted_by_at_most_one_line_of_60_characters(value, shown):
    assert quoted(value) == shown


def test_a_shortened_text_keeps_a_short_line_whole():
    assert shortened("1.5") == "1.5"
    assert shortened("1" * 61) == "1" * 60 + "…"


@pytest.mark.parametrize(
    "digits, message",
    [
        # more digits than Python reads into an int: refused, not a crash
        (5000, "repeat must be >= 1, got a whole number 5000 digits long"),
        (
            300,
            "repeat 1e+299 x 2 keyframe(s) = 2e+299 keyframes to play; at most 10000 are played "
            "in one motion: at most 5000 times",
        ),
    ],
)
def test_a_huge_whole_number_is_one_short_line(tmp_path, capsys, digits, message):
    path = motion_file(
        tmp_path, "  - pose: {shoulder: 30}\n", head=f"repeat: 1{'0' * (digits - 1)}\n"
    )
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == f"choreo: error: {path}:3:9: {message}"


def test_fmt_writes_whole_numbers_exactly_up_to_16_digits():
    from choreo.core.yaml_source import fmt

    assert [fmt(v) for v in (7, 10**16 - 1, 10**16, -(10**400), 0.5)] == [
        "7",
        "9999999999999999",
        "1e+16",
        "-1e+400",
        "0.5",
    ]


def test_every_kind_of_scalar_is_tagged_as_pyyaml_s_own_loader_tags_it(tmp_path):
    scalars = [*PLAIN_NUMBERS, *OTHER_VALUES[:-1], "", "null", "Null", "yes", "off", "~"]
    scalars += ["2026-11-27", "<<", "=", "text", "'quoted 5'", '"5"', "-", ".5", "+.inf"]
    path = tmp_path / "f.yaml"
    path.write_text("".join(f"- {text}\n" for text in scalars))
    ours = parse_yaml_file(path)
    pyyaml = yaml.compose(path.read_text(), Loader=yaml.SafeLoader)
    assert repr(ours) == repr(pyyaml)  # every node's tag and value, nested ones too


def test_lists_64_deep_are_read_and_the_65th_is_refused_where_it_opens(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text("[" * 64 + "1" + "]" * 64 + "\n")
    node = parse_yaml_file(path)
    for _ in range(63):
        node = node.value[0]
    assert node.value[0].value == "1"
    path.write_text("[" * 65 + "1" + "]" * 65 + "\n")
    with pytest.raises(SourceError) as raised:
        parse_yaml_file(path)
    assert str(raised.value) == (
        f"{path}:1:65: nested more than 64 lists or mappings deep; robot and motion files need a "
        "few levels"
    )
