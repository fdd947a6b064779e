"""choreo.core.yaml_source: YAML read with file:line:column for every value, bounded in size, and
a hint where YAML 1.1 reads a number as text."""

from __future__ import annotations

import pytest
from cli_helpers import error_line, motion_file

from choreo.cli import main


@pytest.mark.parametrize(
    "written, hint", [("1e12", "1.0e+12"), ("2.5E3", "2.5e+3"), ("7.e2", "7.0e+2")]
)
def test_a_yaml_1_1_exponent_read_as_text_gets_a_hint(tmp_path, capsys, written, hint):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    after: {written}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:6:12: after must be a number >= 0, got {written!r} "
        f"(YAML reads {written} as text: write {hint})"
    )


def test_validate_reads_at_most_16_mib(capsys):
    assert main(["validate", "/dev/zero"]) == 1
    assert capsys.readouterr().out == (
        "/dev/zero:1:1: cannot read the file: it is larger than 16 MiB, the most a robot or "
        "motion file may be\n"
    )
