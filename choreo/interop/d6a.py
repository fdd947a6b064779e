"""Hiwonder action groups (``.d6a``) <-> choreo motions.

An action group is an SQLite database with one table, ``ActionGroup``: per row an ``Index``
(play order), a ``Time`` (milliseconds to move from the previous row's pose into this row's)
and one ``ServoK`` column per servo holding its target position in units (0..1000). The
vendor's runner sends every row as linear moves of ``Time`` ms and sleeps ``Time``; row 1 starts
from wherever the robot is. See ``docs/d6a.md``.

Import: each row becomes a keyframe arriving ``after: Time/1000`` seconds after the one before,
so every time is kept to the millisecond. Row 1 is reached by choreo's approach (from wherever
the robot is); its ``after`` is then spent at that pose, just as the vendor's runner spends it
when the robot already stands there, and is the time to come back to it when the motion
repeats. Column ``ServoK`` is servo ID K unless the caller gives the IDs column by column.
Positions outside a joint's limits are errors (every one reported at once), never clamped.

Export: one row per played keyframe (``repeat`` unrolled, ``speed`` applied) and rows repeating
the pose for each hold (split into rows of at most 30 s), ``Time`` = the time between leaving
one keyframe and reaching the next, from the keyframes' own times or, for keyframes timed "as
soon as possible", from the planner; whole milliseconds on the motion's clock, so the rows add
up to the motion's duration. The vendor's runner moves in straight lines between rows: a
keyframe's ``stop`` and ``velocity`` and the planner's smoothing have no equivalent in the file.
"""

from __future__ import annotations

import contextlib
import logging
import math
import re
import sqlite3
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeGuard

from choreo.core.atomic import atomic_output, write_text_atomically
from choreo.core.file_kind import not_a_file
from choreo.core.yaml_source import SourceLocation, fmt, quoted
from choreo.errors import SourceError
from choreo.motion.motion_file import HOME_POSE, Keyframe, Motion
from choreo.motion.music_block import repetition_clock
from choreo.motion.timing import PlayedKeyframe, known_arrivals_s, played_keyframes
from choreo.motion.writer import motion_text, robot_reference
from choreo.plan.approach import slow_approach
from choreo.plan.planner import plan_motion
from choreo.robot.types import Joint, Robot

log = logging.getLogger(__name__)

TABLE = "ActionGroup"
INDEX_COLUMN = "Index"
TIME_COLUMN = "Time"
SERVO_COLUMN = re.compile(r"Servo(\d+)", re.IGNORECASE)  # SQLite names ignore case
TIME_RANGE_MS = (20, 30000)  # what the vendor's editor accepts
ANGLE_DECIMALS = 4  # 0.0001° = 0.0004 units: exact enough that export gives back every unit


@dataclass(frozen=True)
class ActionRow:
    index: int  # the row's Index: rows play in this order
    time_ms: float | None  # ms to move from the previous row into this one; None if NULL
    positions_units: tuple[float | None, ...]  # one per servo column; None where NULL


@dataclass(frozen=True)
class ActionGroup:
    path: Path
    servo_columns: tuple[str, ...]  # e.g. ("Servo1", ..., "Servo18"), in table order
    rows: tuple[ActionRow, ...]


# --- reading ----------------------------------------------------------------------------------


def read_action_group(path: str | Path) -> ActionGroup:
    """Read a .d6a file (opened read-only); ``SourceError`` with one line saying what is wrong
    if it is not an action group. Values are taken as they are; see ``keyframes_from_group``."""
    path = Path(path)
    kind = not_a_file(path)
    if kind is not None:
        raise SourceError(f"{path}: is {kind}, not an action group (.d6a) file")
    if not path.is_file():
        raise SourceError(f"{path}: no such file")
    uri = f"{path.resolve().as_uri()}?mode=ro"
    try:
        with contextlib.closing(sqlite3.connect(uri, uri=True)) as connection:
            tables = [
                name
                for (name,) in connection.execute(
                    "SELECT name FROM sqlite_master WHERE type = 'table'"
                )
            ]
            if TABLE not in tables:
                raise SourceError(
                    f"{path}: not a Hiwonder action group: it has no {TABLE} table "
                    f"(tables: {', '.join(tables) or 'none'})"
                )
            cursor = connection.execute(f'SELECT * FROM {TABLE} ORDER BY "{INDEX_COLUMN}"')
            columns = [description[0] for description in cursor.description]
            records = cursor.fetchall()
    except sqlite3.DatabaseError as error:
        raise SourceError(
            f"{path}: not a Hiwonder action group: SQLite cannot read it ({error})"
        ) from None
    return _group_from_records(path, columns, records)


def _group_from_records(path: Path, columns: list[str], records: list[tuple]) -> ActionGroup:
    at = {name.lower(): k for k, name in enumerate(columns)}
    missing = [name for name in (INDEX_COLUMN, TIME_COLUMN) if name.lower() not in at]
    servo_columns = [name for name in columns if SERVO_COLUMN.fullmatch(name)]
    if missing or not servo_columns:
        wanted = ", ".join([*missing] + ([] if servo_columns else ["Servo1..ServoN"]))
        raise SourceError(
            f"{path}: not a Hiwonder action group: its {TABLE} table has no "
            f"{wanted} column (columns: {', '.join(columns)})"
        )
    if not records:
        raise SourceError(f"{path}: the action group has no rows")
    known = {name.lower() for name in (INDEX_COLUMN, TIME_COLUMN, *servo_columns)}
    ignored = [name for name in columns if name.lower() not in known]
    if ignored:
        log.warning(
            "%s: ignoring columns %s (neither Index, Time nor ServoK)", path, ", ".join(ignored)
        )
    index, time = at[INDEX_COLUMN.lower()], at[TIME_COLUMN.lower()]
    servos = [at[name.lower()] for name in servo_columns]
    rows = tuple(
        ActionRow(
            index=record[index],
            time_ms=record[time],
            positions_units=tuple(record[k] for k in servos),
        )
        for record in records
    )
    return ActionGroup(path, tuple(servo_columns), rows)


def column_servo_ids(group: ActionGroup, ids: Sequence[int] | None = None) -> tuple[int, ...]:
    """The servo ID of each servo column: ``ServoK`` is ID K, or with ``ids``, the K-th column
    (in table order) is ``ids[K-1]`` (e.g. SpiderPi-style files: IDs 1..18, 21..25)."""
    if ids is None:
        return tuple(_column_number(name) for name in group.servo_columns)
    if len(ids) != len(group.servo_columns) or len(set(ids)) != len(ids):
        raise SourceError(
            f"{group.path}: {len(group.servo_columns)} servo columns but "
            f"{len(set(ids))} different servo IDs given; give one ID per column, "
            f"in column order"
        )
    return tuple(ids)


# --- rows -> keyframes -------------------------------------------------------------------------


def keyframes_from_group(
    group: ActionGroup, robot: Robot, ids: Sequence[int] | None = None
) -> tuple[Keyframe, ...]:
    """One keyframe per row (see the module docstring). NULL cells and joints without a column
    keep the previous row's angle (the home pose before row 1). ``SourceError`` lists every
    problem: unknown servo IDs, non-numbers, negative times, positions outside the limits."""
    servo_ids = column_servo_ids(group, ids)
    joints = {joint.servo_id: joint for joint in robot.joints}
    problems = _unknown_columns(group, robot, servo_ids, joints)
    current = dict(zip(robot.joint_names, robot.pose_vector(HOME_POSE)))
    keyframes = []
    for row in group.rows:
        where = f"{group.path}: row {row.index}"
        after_s = _row_time_s(row, where, problems)
        for column, servo_id, value in zip(group.servo_columns, servo_ids, row.positions_units):
            joint = joints.get(servo_id)
            if joint is None or value is None:
                continue
            angle = _angle(joint, value, f"{where}, column {column}", problems)
            if angle is not None:
                current[joint.name] = angle
        keyframes.append(
            Keyframe(
                targets_deg=tuple(current[name] for name in robot.joint_names),
                where=SourceLocation(group.path, row.index, 1),
                after_s=after_s,
            )
        )
    if problems:
        raise SourceError(problems)
    return tuple(keyframes)


def _unknown_columns(
    group: ActionGroup, robot: Robot, servo_ids: Sequence[int], joints: dict[int, Joint]
) -> list[str]:
    """Columns with values for servos the robot does not have (all-NULL columns are fine)."""
    problems = []
    for k, (column, servo_id) in enumerate(zip(group.servo_columns, servo_ids)):
        if servo_id not in joints and any(row.positions_units[k] is not None for row in group.rows):
            problems.append(
                f"{group.path}: column {column} (servo ID {servo_id}): robot "
                f"{robot.name!r} has no joint with servo ID {servo_id} (its IDs: "
                f"{', '.join(str(i) for i in sorted(joints))})"
            )
    return problems


def _row_time_s(row: ActionRow, where: str, problems: list[str]) -> float | None:
    """The row's Time in seconds, exactly as many milliseconds as written; None if NULL."""
    value = row.time_ms
    if value is None:
        return None
    if not _is_number(value) or value < 0:
        problems.append(
            f"{where}, column {TIME_COLUMN}: {quoted(value)} is not a time; Time is the "
            f"milliseconds to move here from the previous row, a number >= 0"
        )
        return None
    return round(value / 1000, 6)  # milliseconds, to the microsecond, without float noise


def _angle(joint: Joint, value, where: str, problems: list[str]) -> float | None:
    """The joint angle for a servo position, rounded to what will be written, inside limits."""
    limits = joint.limits
    if not _is_number(value):
        problems.append(
            f"{where} (joint {joint.name}): {quoted(value)} is not a servo position; "
            f"give a number of units, 0..1000"
        )
        return None
    angle = round(joint.to_deg(value), ANGLE_DECIMALS) + 0.0  # + 0.0: no -0.0
    if not limits.contains(angle):
        low, high = (round(units, 1) for units in joint.limits_units)
        problems.append(
            f"{where} (joint {joint.name}): {fmt(value)} units = {fmt(angle)}° is "
            f"outside the joint's limits {limits.range_text} "
            f"(servo positions {fmt(low)}..{fmt(high)})"
        )
        return None
    return angle


def _column_number(name: str) -> int:
    """K of a ``ServoK`` column (reading an action group keeps only columns named so)."""
    match = SERVO_COLUMN.fullmatch(name)
    if match is None:
        raise ValueError(f"{name!r} is not a servo column (ServoK)")
    return int(match.group(1))


def _is_number(value: object) -> TypeGuard[float]:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def import_d6a(
    path: str | Path, robot: Robot, out: str | Path, ids: Sequence[int] | None = None
) -> tuple[Keyframe, ...]:
    """Read an action group and write it as a motion file ``out`` (atomically)."""
    group = read_action_group(path)
    keyframes = keyframes_from_group(group, robot, ids)
    out = Path(out)
    write_text_atomically(
        out, motion_yaml(group, robot, keyframes, robot_reference(robot, out), ids)
    )
    return keyframes


def motion_yaml(
    group: ActionGroup,
    robot: Robot,
    keyframes: Sequence[Keyframe],
    robot_ref: str,
    ids: Sequence[int] | None = None,
) -> str:
    """The motion file text for imported keyframes, with comments saying where they came from."""
    servo_ids = set(column_servo_ids(group, ids))
    uncovered = [joint.name for joint in robot.joints if joint.servo_id not in servo_ids]
    timed = [row.time_ms for row in group.rows if _is_number(row.time_ms)]
    rows = len(group.rows)
    header = [
        f"Imported by `choreo import d6a` from {group.path.name}, a Hiwonder action group",
        f"of {rows} row{'s' if rows != 1 else ''} taking {fmt(sum(timed) / 1000)} s.",
        "Each row is one keyframe; `after` is the row's Time: the seconds the vendor's runner",
        "takes to move from the previous row into this one. A keyframe names only the joints",
        "whose servo positions differ from the row before (row 1: from the home pose).",
    ]
    if uncovered:
        header.append(f"The file has no column for {', '.join(uncovered)}: they stay at home.")
    comments = {
        k: f"row {row.index}"
        if row.time_ms is not None
        else f"row {row.index}: its Time is NULL: reached as soon as the limits allow"
        for k, row in enumerate(group.rows)
    }
    first = group.rows[0]
    comments[0] = (
        f"row {first.index} is reached from wherever the robot is: choreo's approach "
        f"brings the robot\nto this pose first. "
        + (
            "The row's Time is then spent here (as the vendor's runner does when\n"
            "the robot already stands here) and is the time to come back here on "
            "repeat."
            if first.time_ms is not None
            else "Its Time is NULL: the motion goes on from here at once."
        )
    )
    return motion_text(
        robot,
        keyframes,
        robot_ref=robot_ref,
        description=f"Hiwonder action group {group.path.name}",
        header=header,
        comments=comments,
    )


# --- motion -> rows ----------------------------------------------------------------------------


def rows_from_motion(motion: Motion) -> tuple[tuple[str, ...], tuple[ActionRow, ...]]:
    """(servo columns, rows) for a motion: ``ServoK`` for every servo ID K of the robot, rows
    as described in the module docstring. ``SourceError`` lists every keyframe whose Time would
    fall outside 20..30000 ms, at the keyframe's line."""
    robot = motion.robot
    joints = sorted(robot.joints, key=lambda joint: joint.servo_id)
    columns = tuple(f"Servo{joint.servo_id}" for joint in joints)
    order = [robot.joints.index(joint) for joint in joints]
    played, arrivals_s = _played(motion)
    rows: list[ActionRow] = []
    problems: list[str] = []
    left_ms = 0  # when the keyframe before was left; whole ms, so row times add up exactly
    for k, (p, arrive_s) in enumerate(zip(played, arrivals_s)):
        arrive_ms = round(1000 * arrive_s)
        time_ms = arrive_ms - left_ms
        if k == 0 and (_untimed(p.keyframe) or time_ms == 0):
            # `t: 0` on the first keyframe is where the motion starts, like no time at all:
            # row 1 is reached by the approach
            time_ms = _first_move_ms(robot, p.keyframe)
        positions = tuple(
            float(round(robot.joints[j].to_units(p.keyframe.targets_deg[j]))) for j in order
        )
        _check_ms(
            time_ms,
            p.keyframe,
            f"is reached {fmt(time_ms / 1000)} s after the keyframe before it is left",
            problems,
        )
        rows.append(ActionRow(len(rows) + 1, time_ms, positions))
        left_ms = round(1000 * (arrive_s + p.hold_s))
        hold_ms = left_ms - arrive_ms  # rows of their own; a long one split, not refused
        if 0 < hold_ms < TIME_RANGE_MS[0]:
            _check_ms(hold_ms, p.keyframe, f"holds {fmt(hold_ms / 1000)} s", problems)
        if hold_ms:
            rows += [
                ActionRow(len(rows) + 1 + n, piece, positions)
                for n, piece in enumerate(_pieces_ms(hold_ms))
            ]
    if problems:
        raise SourceError(problems)
    return columns, tuple(rows)


def _pieces_ms(total_ms: int) -> list[int]:
    """A hold as rows no longer than the editor allows, as equal as whole ms can be."""
    count = -(-total_ms // TIME_RANGE_MS[1])
    return [total_ms // count + (1 if n < total_ms % count else 0) for n in range(count)]


def _untimed(keyframe: Keyframe) -> bool:
    return keyframe.t_s is None and keyframe.after_s is None


def _first_move_ms(robot: Robot, first: Keyframe) -> int:
    """Row 1's Time for an untimed first keyframe: as long as choreo's approach from the home
    pose takes, and at least the editor's 20 ms (the runner needs a move time even if the
    robot is already there)."""
    approach = slow_approach(robot, robot.pose_vector(HOME_POSE), first.targets_deg)
    time_ms = max(math.ceil(1000 * approach.duration_s), TIME_RANGE_MS[0])
    log.info(
        "%s: the first keyframe has no time: row 1 gets %d ms, the approach from home",
        first.where,
        time_ms,
    )
    return time_ms


def _check_ms(time_ms: int, keyframe: Keyframe, what: str, problems: list[str]) -> None:
    """A row's Time outside the editor's range is reported at its keyframe."""
    low, high = TIME_RANGE_MS
    if not low <= time_ms <= high:
        fix = (
            f"give it at least {low / 1000:g} s"
            if time_ms < low
            else "split the move with keyframes in between"
        )
        problems.append(
            f"{keyframe.where}: this keyframe {what}, but an action group row's Time "
            f"must be {low}..{high} ms (the vendor editor's range): {fix}"
        )


def _played(motion: Motion) -> tuple[list[PlayedKeyframe[Keyframe]], list[float]]:
    """The played keyframes and their arrival times: from their own t/after where every keyframe
    has one (the first may go without), else from the planner."""
    played = played_keyframes(
        motion.keyframes,
        repeat=motion.repeat,
        speed=motion.speed,
        repetition_at=repetition_clock(motion.music, motion.keyframes),
    )
    own = known_arrivals_s(played)
    if None in own:
        return played, list(plan_motion(motion).trajectory.keyframe_times_s)
    return played, [arrival for arrival in own if arrival is not None]


# --- writing -----------------------------------------------------------------------------------


def schema_sql(servo_columns: Sequence[str]) -> str:
    """The ActionGroup table as the vendor's editor creates it."""
    indent = " " * 4
    lines = [
        f"CREATE TABLE {TABLE}([{INDEX_COLUMN}] INTEGER PRIMARY KEY AUTOINCREMENT",
        f"{indent}NOT NULL ON CONFLICT FAIL",
        f"{indent}UNIQUE ON CONFLICT ABORT,",
        f"{indent}{TIME_COLUMN} INT,",
    ]
    lines += [f"{indent}{name} INT," for name in servo_columns]
    lines[-1] = lines[-1].removesuffix(",") + ")"
    return "\n".join(lines)


def write_action_group(
    path: str | Path, servo_columns: Sequence[str], rows: Sequence[ActionRow]
) -> None:
    """Write an action group file atomically: whole numbers, the vendor's schema."""
    columns = [INDEX_COLUMN, TIME_COLUMN, *servo_columns]
    insert = (
        f"INSERT INTO {TABLE} ({', '.join(f'[{name}]' for name in columns)}) "
        f"VALUES ({', '.join('?' * len(columns))})"
    )
    values = [
        (row.index, _whole(row.time_ms), *(_whole(p) for p in row.positions_units)) for row in rows
    ]
    with atomic_output(Path(path)) as temporary:
        with contextlib.closing(sqlite3.connect(temporary)) as connection:
            connection.execute(schema_sql(servo_columns))
            connection.executemany(insert, values)
            connection.commit()


def _whole(value: float | None) -> int | None:
    return None if value is None else int(round(value))


def export_d6a(motion: Motion, out: str | Path) -> tuple[ActionRow, ...]:
    """Write ``motion`` as an action group file ``out``; the rows written."""
    columns, rows = rows_from_motion(motion)
    write_action_group(out, columns, rows)
    return rows
