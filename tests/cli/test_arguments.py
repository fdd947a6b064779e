"""choreo.cli.arguments and the commands' own argument types: every number and ID range a user
types is bounded, and a refusal says what would be valid; choreo.core.arguments: the ranges the
library checks its arguments against, which the flags share."""

from __future__ import annotations

import math
import os
import signal

import pytest
from cli_helpers import WAVE, usage_error_line

from choreo.bus.settings import TIMEOUT_S
from choreo.cli import build_parser, main
from choreo.cli.arguments import ctrl_c_deferred
from choreo.core.arguments import COUNT, NON_NEGATIVE, NUMBER, POSITIVE
from choreo.errors import OptionError
from choreo.plan.ticks import TOLERANCE_DEG
from choreo.play.play_options import PlayOptions


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["scan", "--timeout-ms", "1e308"],
            "choreo scan: error: argument --timeout-ms: expected a number > 0 and <= 5000 ms, "
            "got '1e308'",
        ),
        (
            ["play", str(WAVE), "--health-timeout-ms", "1e308"],
            "choreo play: error: argument --health-timeout-ms: expected a number > 0 and "
            "<= 5000 ms, got '1e308'",
        ),
        (
            ["emulate", "--pty", "x", "--turnaround-ms", "1e308"],
            "choreo emulate: error: argument --turnaround-ms: expected a number in 0..1000 ms, "
            "got '1e308'",
        ),
        (
            ["scan", "--retries", "10"],
            "choreo scan: error: argument --retries: invalid choice: 10 (choose from 0, 1, 2, 3, "
            "4, 5, 6, 7, 8, 9)",
        ),
    ],
)
def test_timer_options_are_bounded(capsys, argv, line):
    assert usage_error_line(capsys, argv) == line


def test_an_open_ended_id_range_is_an_error(capsys):
    assert usage_error_line(capsys, ["scan", "--ids", "1-"]) == (
        "choreo scan: error: argument --ids: servo IDs must look like '1-6,9', got '1-'"
    )


def test_emulate_with_an_empty_pty_path_says_so(capsys):
    assert usage_error_line(capsys, ["emulate", "--pty", ""]) == (
        "choreo emulate: error: argument --pty: the path is empty: give a path for the link, "
        "e.g. /tmp/ttyCHOREO"
    )


def test_plan_tolerance_has_a_maximum(capsys):
    assert usage_error_line(capsys, ["plan", str(WAVE), "--tolerance", "1000"]) == (
        "choreo plan: error: argument --tolerance: expected a number > 0 and <= 5°, got '1000'"
    )
    assert main(["plan", str(WAVE), "--tolerance", "5"]) == 0


# --- the ranges the library and the command line share (choreo.core.arguments) ----------------
def test_a_range_says_its_bounds_in_words():
    assert [str(r) for r in (NUMBER, POSITIVE, NON_NEGATIVE, COUNT, TOLERANCE_DEG)] == [
        "a number",
        "a number > 0",
        "a number >= 0",
        "a whole number >= 1",
        "a number > 0 and <= 5°",
    ]
    assert str(TIMEOUT_S.scaled(1000, " ms")) == "a number > 0 and <= 5000 ms"


@pytest.mark.parametrize(
    "valid, value, number",
    [
        (POSITIVE, 2, 2.0),
        (POSITIVE, 10**400, None),  # beyond any float
        (POSITIVE, True, None),  # a flag, not a number
        (POSITIVE, math.nan, None),
        (COUNT, 3, 3),
        (COUNT, 3.0, None),  # a whole number is an int
        (COUNT, 10**400, 10**400),  # whole and finite, however large
        (NON_NEGATIVE, -0.0, 0.0),
        (TOLERANCE_DEG, 5, 5.0),
        (TOLERANCE_DEG, 5.000001, None),
    ],
)
def test_a_range_takes_only_numbers_inside_it(valid, value, number):
    assert valid.number(value) == number
    assert (value in valid) is (number is not None)


@pytest.mark.parametrize(
    "text, value",
    [
        ("0", 0),
        ("0.01", 0.01),
        ("5", 5),
        ("5.01", 5.01),
        ("-1", -1),
        ("nan", math.nan),
        ("inf", math.inf),
        ("1e308", 1e308),
    ],
)
def test_the_tolerance_flag_and_argument_take_the_same_values(capsys, text, value):
    try:
        build_parser(["play"]).parse_args(["play", str(WAVE), "--tolerance", text])
        flag = None
    except SystemExit:
        flag = capsys.readouterr().err.splitlines()[-1]
    try:
        PlayOptions(tolerance_deg=value)
        argument = None
    except OptionError as error:
        argument = str(error)
    assert (flag is None) == (argument is None) == (0 < value <= 5)
    if flag is not None:
        assert flag.endswith(f"--tolerance: expected {TOLERANCE_DEG}, got {text!r}")
        assert argument == f"tolerance_deg must be {TOLERANCE_DEG}, got {value!r}"


def test_ctrl_c_inside_a_deferred_block_arrives_when_it_ends():
    """Around a compiled module's import: the block runs to its end, then KeyboardInterrupt."""
    done = []
    with pytest.raises(KeyboardInterrupt):
        with ctrl_c_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # the handler runs between bytecodes: it has had its chance
                done.append(len(done))
    assert len(done) == 1000
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored


@pytest.mark.parametrize(
    "argv, argument",
    [
        (["plan", ""], "MOTION"),
        (["validate", ""], "FILE"),
        (["beats", " "], "SONG"),
        (["mirror", str(WAVE), "-o", ""], "-o/--output"),
    ],
)
def test_an_empty_path_is_refused_as_empty_not_taken_for_the_current_folder(capsys, argv, argument):
    assert usage_error_line(capsys, argv) == (
        f"choreo {argv[0]}: error: argument {argument}: the path is empty: give a file's path"
    )
