"""choreo import, export and mirror as a user runs them: the vendor's files both ways, and one
line for a file that is not one."""

from __future__ import annotations

import re
import shutil
import sqlite3
from contextlib import closing

import pytest
from cli_helpers import error_line, mirror, write_d6a
from d6a_helpers import VENDOR, VENDOR_FILES, edited_copy, import_to, sqlite_rows
from paths import DATA, REPO

from choreo.cli import main
from choreo.motion.motion_file import load_motion
from choreo.validate import check_file

ARM6 = REPO / "motions" / "arm6"


@pytest.mark.parametrize("source", VENDOR_FILES, ids=lambda p: p.stem)
def test_every_vendor_file_imports_loads_and_exports_back_to_the_same_rows(source, tmp_path):
    """Loading checks the format, the robot and every angle against its limits. (Planning on
    time and the physics preview, which ``choreo validate`` adds, are for the robot's own
    motions: several vendor files ask for more than the servos can do; see below.)"""
    out = import_to(tmp_path, source)
    assert len(load_motion(out).keyframes) == len(sqlite_rows(source))
    back = tmp_path / "back.d6a"
    assert main(["export", "d6a", str(out), "-o", str(back)]) == 0
    original, exported = sqlite_rows(source), sqlite_rows(back)
    assert len(exported) == len(original)
    for row, (want, got) in enumerate(zip(original, exported), start=1):
        assert len(got) == len(want)
        assert got[0] == want[0] == row  # Index
        assert abs(got[1] - want[1]) <= 1, f"row {row}: Time"  # ms
        for column, (a, b) in enumerate(zip(want[2:], got[2:]), start=1):
            assert abs(a - b) <= 1, f"row {row}, Servo{column}"
            assert isinstance(b, int)


def test_positions_outside_the_limits_are_all_reported_at_their_row_and_column(tmp_path, capsys):
    bad = edited_copy(
        VENDOR / "wave.d6a",
        tmp_path / "bad.d6a",
        'UPDATE ActionGroup SET Servo16 = 1000 WHERE "Index" = 3',
        'UPDATE ActionGroup SET Servo3 = 990 WHERE "Index" = 5',
    )
    out = tmp_path / "bad.yaml"
    assert main(["import", "d6a", str(bad), "--robot", "tonypi", "-o", str(out)]) == 1
    assert capsys.readouterr().err.splitlines() == [
        f"choreo: error: {bad}: row 3, column Servo16 (joint right_shoulder_pitch): 1000 units = "
        f"174° is outside the joint's limits -60..170° (servo positions 25..983.3)",
        f"{bad}: row 5, column Servo3 (joint left_knee): 990 units = 164.88° is outside the "
        f"joint's limits -72.72..155° (servo positions 0..948.8)",
    ]
    assert not out.exists()


def test_a_file_that_is_not_sqlite_is_one_clear_line(tmp_path, capsys):
    text = tmp_path / "notes.d6a"
    text.write_text("Time,Servo1\n500,500\n")
    out = tmp_path / "x.yaml"
    assert main(["import", "d6a", str(text), "--robot", "tonypi", "-o", str(out)]) == 1
    assert capsys.readouterr().err.splitlines() == [
        f"choreo: error: {text}: not a Hiwonder action group: SQLite cannot read it (file is "
        f"not a database)"
    ]


def test_a_database_without_an_action_group_table_is_one_clear_line(tmp_path, capsys):
    other = tmp_path / "other.d6a"
    with closing(sqlite3.connect(other)) as connection:
        connection.execute("CREATE TABLE Moves (Time INT, Servo1 INT)")
    out = tmp_path / "x.yaml"
    assert main(["import", "d6a", str(other), "--robot", "tonypi", "-o", str(out)]) == 1
    assert capsys.readouterr().err.splitlines() == [
        f"choreo: error: {other}: not a Hiwonder action group: it has no ActionGroup table "
        f"(tables: Moves)"
    ]


def test_a_missing_file_is_named(tmp_path, capsys):
    assert (
        main(
            [
                "import",
                "d6a",
                str(tmp_path / "nope.d6a"),
                "--robot",
                "tonypi",
                "-o",
                str(tmp_path / "x.yaml"),
            ]
        )
        == 1
    )
    assert capsys.readouterr().err == f"choreo: error: {tmp_path / 'nope.d6a'}: no such file\n"


@pytest.mark.parametrize("source", VENDOR_FILES, ids=lambda p: p.stem)
def test_every_vendor_file_imports_and_validates_or_says_precisely_why_not(source, tmp_path):
    """The user's way: `choreo import d6a`, then `choreo validate` (planning and ticks). A file
    either validates, or every problem names its keyframe's line, the limiting joint and the
    earliest feasible time, and `--stretch` then validates it."""
    out = tmp_path / f"{source.stem}.yaml"
    assert main(["import", "d6a", str(source), "--robot", "tonypi", "-o", str(out)]) == 0
    result = check_file(out, physics=False)
    for problem in result.problems:
        assert re.match(
            rf"^{re.escape(str(out))}:\d+:\d+: keyframe cannot be reached at [\d.]+ s"
            r".*limits of \w+ allow [\d.]+ s at the earliest",
            problem,
        ), problem
    assert check_file(out, physics=False, stretch=True).ok


def test_the_shipped_dance_exports(tmp_path, capsys):
    """Its first keyframe is at t 0: row 1 is reached by the approach, like an untimed one."""
    from choreo.motion.motion_file import load_motion

    out = tmp_path / "dance.d6a"
    dance = REPO / "motions" / "arm6" / "dance.yaml"
    assert main(["export", "d6a", str(dance), "-o", str(out)]) == 0
    assert load_motion(dance).keyframes[0].t_s == 0.0  # on beat 1 of its song
    assert re.fullmatch(
        rf"wrote {re.escape(str(out))}: \d+ rows, [\d.]+ s, from {re.escape(str(dance))}\n",
        capsys.readouterr().out,
    )


def test_import_ids_keep_the_order_given(tmp_path):
    """Column k is the k-th ID as written: 6,4,2 puts Servo1's 700 on the gripper (ID 6)."""
    from choreo.motion.motion_file import load_motion

    out = tmp_path / "out.yaml"
    d6a = write_d6a(tmp_path / "in.d6a")
    argv = ["import", "d6a", str(d6a), "--robot", "arm6", "-o", str(out), "--ids", "6,4,2"]
    assert main(argv) == 0
    motion = load_motion(out)
    first = dict(zip(motion.robot.joint_names, motion.keyframes[0].targets_deg))
    # row 1: Servo1 500 -> gripper (zero 700, direction -1): +48°; Servo3 700 -> shoulder +48°
    assert (first["gripper"], first["wrist_pitch"], first["shoulder"]) == (48.0, 0.0, 48.0)


def test_importing_a_folder_says_it_is_a_folder(tmp_path, capsys):
    argv = ["import", "d6a", str(tmp_path), "--robot", "arm6", "-o", str(tmp_path / "o.yaml")]
    assert main(argv) == 1
    assert error_line(capsys) == (
        f"choreo: error: {tmp_path}: is a folder, not an action group (.d6a) file"
    )


def test_a_mirrored_arm6_wave_validates_and_turns_yaw_and_roll_the_other_way(tmp_path, capsys):
    """arm6 mirrors base_yaw and wrist_roll with sign -1; wave_block turns to 60° and rolls the
    hand to -30° first, and faces forward again at the end."""
    out = mirror(ARM6 / "wave.yaml", tmp_path / "wave_mirrored.yaml")
    assert main(["validate", "--no-physics", str(out)]) == 0, capsys.readouterr().out
    block = load_motion(mirror(ARM6 / "wave_block.yaml", tmp_path / "block_mirrored.yaml"))
    names = block.robot.joint_names
    yaw, roll = names.index("base_yaw"), names.index("wrist_roll")
    assert [(k.targets_deg[yaw], k.targets_deg[roll]) for k in block.keyframes] == [
        (-60, 30)
    ] * 5 + [(0, 0)]
    assert main(["validate", "--no-physics", str(block.path)]) == 0, capsys.readouterr().out


def test_tonypi_wave_with_the_right_arm_becomes_a_wave_with_the_left(tmp_path, capsys):
    source = tmp_path / "wave.yaml"
    assert (
        main(
            [
                "import",
                "d6a",
                str(REPO / "tests" / "data" / "tonypi" / "wave.d6a"),
                "--robot",
                "tonypi",
                "-o",
                str(source),
            ]
        )
        == 0
    )
    motion = load_motion(mirror(source, tmp_path / "wave_left.yaml"))
    raised = dict(zip(motion.robot.joint_names, motion.keyframes[1].targets_deg))
    assert raised["left_shoulder_pitch"] == 122.88 and raised["right_shoulder_pitch"] == 0
    assert raised["left_elbow"] == 43.92 and raised["right_elbow"] == 18


def test_a_robot_without_mirror_pairs_is_an_error(tmp_path, capsys):
    models = tmp_path / "models" / "tiny"
    shutil.copytree(DATA / "models" / "tiny", models)
    robot_file = models / "robot.yaml"
    text = robot_file.read_text()
    robot_file.write_text(text[: text.index("mirror:")])
    source = tmp_path / "swing.yaml"
    source.write_text("robot: tiny\nkeyframes:\n  - pose: wave\n")
    assert main(["mirror", str(source), "-o", str(tmp_path / "out.yaml")]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: {robot_file}: robot 'tiny' has no mirror pairs, so {source} cannot be "
        f"mirrored; add 'mirror:' pairs to the robot\n"
    )
    assert not (tmp_path / "out.yaml").exists()
