"""Hiwonder action groups: the vendor's real TonyPi files in and out, bad files, and exports of
choreo motions. The vendor files are copied unchanged into ``tests/data/tonypi``."""

from __future__ import annotations

import os
import sqlite3
from contextlib import closing
from pathlib import Path

import pytest
from d6a_helpers import VENDOR, VENDOR_FILES, edited_copy, import_to
from paths import REPO

from choreo.errors import SourceError
from choreo.interop.d6a import (
    ActionRow,
    export_d6a,
    import_d6a,
    keyframes_from_group,
    read_action_group,
    rows_from_motion,
    write_action_group,
)
from choreo.motion.motion_file import Motion, load_motion
from choreo.plan.planner import plan_motion
from choreo.plan.ticks import compile_ticks
from choreo.robot.robot_file import load_robot

SHIPPED = REPO / "motions" / "tonypi"


@pytest.fixture(scope="module")
def tonypi():
    return load_robot("tonypi")


def table_sql(path: Path) -> str:
    with closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as connection:
        return connection.execute(
            "SELECT sql FROM sqlite_master WHERE name = 'ActionGroup'"
        ).fetchone()[0]


# --- the vendor's files ------------------------------------------------------------------------


def test_the_vendor_files_are_there():
    assert len(VENDOR_FILES) == 15


@pytest.mark.parametrize("source", VENDOR_FILES, ids=lambda p: p.stem)
def test_every_vendor_file_plans_and_compiles_with_stretch(source, tonypi):
    """Some rows ask for more than a smooth plan within the servos' speed allows (wave flaps the
    elbow at 298 deg/s and reverses at once); stretched, every file plans and fits the bus."""
    group = read_action_group(source)
    motion = Motion(
        name=source.stem, path=source, robot=tonypi, keyframes=keyframes_from_group(group, tonypi)
    )
    result = plan_motion(motion, stretch=True)
    rows_s = sum(row.time_ms for row in group.rows) / 1000
    assert result.trajectory.duration_s == pytest.approx(
        rows_s + sum(s.shift_s for s in result.stretches), abs=1e-6
    )
    assert compile_ticks(result.trajectory, tonypi).ticks


def test_times_and_angles_of_wave_come_from_its_rows(tmp_path):
    """wave.d6a row 2: Time 500, Servo16 (right shoulder pitch, zero 275) 787 -> 122.88°;
    row 3: Time 200, Servo14 (right elbow, zero 500, direction -1) 177 -> 77.52°."""
    motion = load_motion(import_to(tmp_path, VENDOR / "wave.d6a"))
    robot = motion.robot
    keyframes = motion.keyframes
    assert len(keyframes) == 11
    assert [k.after_s for k in keyframes] == [0.5, 0.5] + [0.2] * 8 + [0.5]
    assert all(k.t_s is None and k.hold_s == 0 and not k.stop for k in keyframes)
    names = robot.joint_names
    assert keyframes[1].targets_deg[names.index("right_shoulder_pitch")] == 122.88
    assert keyframes[2].targets_deg[names.index("right_elbow")] == 77.52
    assert keyframes[3].targets_deg[names.index("right_elbow")] == 18


def test_stand_is_the_home_pose_and_says_how_row_one_is_reached(tmp_path):
    text = import_to(tmp_path, VENDOR / "stand.d6a").read_text()
    assert "  - pose: home\n    after: 0.5\n" in text
    assert "row 1 is reached from wherever the robot is" in text
    assert "robot: tonypi\n" in text


IMPORTED = [p for p in sorted(SHIPPED.glob("*.yaml")) if "choreo import d6a" in p.read_text()]


@pytest.mark.parametrize("shipped", IMPORTED, ids=lambda p: p.stem)
def test_the_shipped_tonypi_motions_are_plain_imports(shipped, tmp_path):
    assert import_to(tmp_path, VENDOR / f"{shipped.stem}.d6a").read_text() == shipped.read_text()


# --- bad files ---------------------------------------------------------------------------------


def test_a_failed_import_leaves_the_old_output_alone(tmp_path, tonypi):
    bad = edited_copy(
        VENDOR / "stand.d6a", tmp_path / "bad.d6a", "UPDATE ActionGroup SET Servo2 = 'x'"
    )
    out = tmp_path / "stand.yaml"
    out.write_text("old")
    with pytest.raises(
        SourceError,
        match=r"row 1, column Servo2 \(joint left_ankle_pitch\): "
        r"'x' is not a servo position",
    ):
        import_d6a(bad, tonypi, out)
    assert out.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.d6a", "stand.yaml"]


def test_nulls_keep_the_previous_value_and_a_null_time_is_as_soon_as_possible(tmp_path):
    source = edited_copy(
        VENDOR / "wave.d6a",
        tmp_path / "gaps.d6a",
        'UPDATE ActionGroup SET Servo14 = NULL WHERE "Index" = 4',
        'UPDATE ActionGroup SET Time = NULL WHERE "Index" = 5',
    )
    motion = load_motion(import_to(tmp_path, source))
    elbow = motion.robot.joint_names.index("right_elbow")
    assert motion.keyframes[3].targets_deg[elbow] == motion.keyframes[2].targets_deg[elbow] == 77.52
    assert motion.keyframes[4].after_s is None and motion.keyframes[4].t_s is None
    assert "row 5: its Time is NULL" in (tmp_path / "gaps.yaml").read_text()


def test_columns_for_servos_the_robot_lacks_are_errors_unless_empty(tmp_path, tonypi):
    source = edited_copy(
        VENDOR / "stand.d6a",
        tmp_path / "extra.d6a",
        "ALTER TABLE ActionGroup ADD COLUMN Servo19 INT",
        "ALTER TABLE ActionGroup ADD COLUMN Servo20 INT",
        "UPDATE ActionGroup SET Servo19 = 500",
    )
    with pytest.raises(SourceError) as error:
        import_d6a(source, tonypi, tmp_path / "extra.yaml")
    assert error.value.problems == [
        f"{source}: column Servo19 (servo ID 19): robot 'tonypi' has no joint with servo ID 19 "
        f"(its IDs: {', '.join(map(str, range(1, 19)))})"
    ]


def test_ids_map_columns_by_position(tmp_path):
    """A 3-column file read with --ids 2,4,6 drives arm6's shoulder, wrist_pitch and gripper."""
    source = tmp_path / "three.d6a"
    write_action_group(
        source,
        ("Servo1", "Servo2", "Servo3"),
        (ActionRow(1, 500, (500, 500, 700)), ActionRow(2, 800, (625, 400, 580))),
    )
    motion = load_motion(import_to(tmp_path, source, "arm6", "--ids", "2,4,6"))
    targets = dict(zip(motion.robot.joint_names, motion.keyframes[1].targets_deg))
    assert targets == {
        "base_yaw": 0,
        "shoulder": 30,
        "elbow": 0,
        "wrist_pitch": -24,
        "wrist_roll": 0,
        "gripper": 28.8,
    }
    assert motion.keyframes[1].after_s == 0.8


# --- exporting choreo motions ------------------------------------------------------------------


def test_exported_files_use_the_vendor_schema(tmp_path):
    out = tmp_path / "stand.d6a"
    export_d6a(load_motion(SHIPPED / "stand.yaml"), out)
    assert table_sql(out).split() == table_sql(VENDOR / "stand.d6a").split()
    with closing(sqlite3.connect(out)) as connection:
        sequence = connection.execute("SELECT * FROM sqlite_sequence").fetchall()
    assert sequence == [("ActionGroup", 1)]


def test_arm6_wave_exports_a_row_per_keyframe_and_per_hold():
    """motions/arm6/wave.yaml: home (untimed: the editor's minimum 20 ms, home needs no
    approach), after 1.0, six flaps of 0.4 s, the last with hold 0.3, home after 1.2."""
    columns, rows = rows_from_motion(load_motion(REPO / "motions" / "arm6" / "wave.yaml"))
    assert columns == tuple(f"Servo{k}" for k in range(1, 7))
    assert [row.time_ms for row in rows] == [20, 1000] + [400] * 6 + [300, 1200]
    assert [row.index for row in rows] == list(range(1, 11))
    assert rows[1].positions_units[:3] == (500, 625, 375)  # base, shoulder 30°, elbow -30°
    assert rows[8].positions_units == rows[7].positions_units  # the hold


def test_untimed_keyframes_take_the_planners_times(tmp_path):
    motion_file = tmp_path / "asap.yaml"
    motion_file.write_text(
        "robot: arm6\nkeyframes:\n  - pose: home\n  - pose: {shoulder: 40}\n"
        "  - pose: {elbow: 30}\n    after: 0.5\n"
    )
    motion = load_motion(motion_file)
    arrive_s = plan_motion(motion).trajectory.keyframe_times_s
    _, rows = rows_from_motion(motion)
    assert [row.time_ms for row in rows] == [20, round(1000 * arrive_s[1]), 500]


def test_speed_and_repeat_are_written_out(tmp_path):
    motion_file = tmp_path / "twice.yaml"
    motion_file.write_text(
        "robot: arm6\nspeed: 2\nrepeat: 2\nkeyframes:\n"
        "  - pose: home\n    after: 0.4\n"
        "  - pose: {shoulder: 40}\n    t: 1.4\n    hold: 0.2\n"
    )
    _, rows = rows_from_motion(load_motion(motion_file))
    # t 1.4 is 1.0 s after the first keyframe; halved by the speed; the wrap takes its after
    assert [row.time_ms for row in rows] == [200, 500, 100, 200, 500, 100]


def test_rows_too_short_or_too_long_are_reported_at_their_keyframes(tmp_path):
    motion_file = tmp_path / "quick.yaml"
    motion_file.write_text(
        "robot: arm6\nkeyframes:\n  - pose: home\n"
        "  - pose: {shoulder: 1}\n    after: 0.01\n"
        "  - pose: {shoulder: 2}\n    after: 31\n"
    )
    with pytest.raises(SourceError) as error:
        rows_from_motion(load_motion(motion_file))
    assert error.value.problems == [
        f"{motion_file}:4:5: this keyframe is reached 0.01 s after the keyframe before it is "
        f"left, but an action group row's Time must be 20..30000 ms (the vendor editor's range): "
        f"give it at least 0.02 s",
        f"{motion_file}:6:5: this keyframe is reached 31 s after the keyframe before it is left, "
        f"but an action group row's Time must be 20..30000 ms (the vendor editor's range): split "
        f"the move with keyframes in between",
    ]


def test_holds_are_rows_of_their_own_split_when_long_refused_when_too_short(tmp_path):
    motion_file = tmp_path / "holds.yaml"
    motion_file.write_text(
        "robot: arm6\nkeyframes:\n  - pose: home\n    after: 0.5\n"
        "    hold: 65\n  - pose: {shoulder: 10}\n    after: 1\n"
        "    hold: 0.01\n"
    )
    with pytest.raises(SourceError) as error:
        rows_from_motion(load_motion(motion_file))
    assert error.value.problems == [
        f"{motion_file}:6:5: this keyframe holds 0.01 s, but an action group row's Time must be "
        f"20..30000 ms (the vendor editor's range): give it at least 0.02 s"
    ]
    motion_file.write_text(motion_file.read_text().replace("hold: 0.01", "hold: 0.02"))
    _, rows = rows_from_motion(load_motion(motion_file))
    assert [row.time_ms for row in rows] == [500, 21667, 21667, 21666, 1000, 20]
    assert len({row.positions_units for row in rows[:4]}) == 1


def test_a_fifo_or_device_given_as_an_action_group_is_named_so(tmp_path):
    fifo = tmp_path / "bow.d6a"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "a FIFO (named pipe)"), (Path("/dev/null"), "a device")):
        with pytest.raises(SourceError) as caught:
            read_action_group(path)
        assert str(caught.value) == f"{path}: is {kind}, not an action group (.d6a) file"
