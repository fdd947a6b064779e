"""Edits of a motion file's keyframes that change only what they must.

Everything outside the edited keyframe stays byte for byte as the author wrote it: the file is
read with ruamel.yaml's round-trip loader to find where each keyframe is, and only that keyframe's
lines are replaced (or new lines inserted). The keyframe itself goes through ruamel.yaml too, so
its own comments, key order and quoting survive an update.
"""

from __future__ import annotations

import functools
import io
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml
from yaml.nodes import MappingNode, SequenceNode

from choreo.core.yaml_source import yaml_problem
from choreo.motion.gait import BodyPose
from choreo.motion.keyframe_entry import TIMING_KEYS  # the loader's: one list of timing keys
from choreo.motion.music_block import BeatGrid
from choreo.studio import require

BEAT_DECIMALS = 3  # a thousandth of a beat: well under a millisecond at any tempo
SPACE_KEYS = ("sites", "body", "gait")  # a joint pose written over a keyframe replaces these
DECIMALS = 1  # degrees and times written with one decimal (0.1° is below a servo's step)
TIME_DECIMALS = 3  # seconds: to the millisecond
_FAST_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's, where PyYAML has it


class EditRefused(ValueError):
    """The edit cannot be made as asked; the message says why (``path:line`` where it can)."""


@dataclass(frozen=True)
class KeyframeItem:
    """One entry of the file's ``keyframes:`` list, by 0-based line numbers."""

    first_line: int  # the line of its "-"
    last_line: int  # its last line with content (comments after it belong to the next one)
    content_line: int  # where its mapping starts (the keyframe's SourceLocation line - 1)
    dash_col: int


def _yaml():
    yaml_module = require("ruamel.yaml")
    yaml = yaml_module.YAML(typ="rt")
    yaml.preserve_quotes = True
    yaml.width = 100  # as choreo.motion.writer wraps
    yaml.indent(mapping=2, sequence=2, offset=0)
    return yaml


@functools.lru_cache(maxsize=8)
def keyframe_items(text: str) -> tuple[KeyframeItem, ...]:
    """The keyframes written in ``text`` (not those of its includes), in file order. Found
    with libyaml's parser, as the motion loader does (same lines; a round-trip parse of a long
    file costs seconds), and kept for the last few texts: an edit tried at several times asks
    for the same file's again."""
    try:
        document = yaml.compose(text, Loader=_FAST_LOADER)
    except yaml.YAMLError as error:
        line, col, problem = yaml_problem(error, text)
        raise EditRefused(f"the file is not valid YAML at {line}:{col}: {problem}") from None
    pairs = document.value if isinstance(document, MappingNode) else []
    keys = [key.value for key, _ in pairs]
    if "keyframes" not in keys or not isinstance(pairs[keys.index("keyframes")][1], SequenceNode):
        raise EditRefused("the file has no keyframes: list")
    at = keys.index("keyframes")
    lines = text.splitlines()
    end = len(lines)
    if at + 1 < len(keys):  # the next top-level key's line, its comments left to it
        end = pairs[at + 1][0].start_mark.line
        while end > 0 and _blank_or_comment(lines[end - 1]):
            end -= 1
    starts = [node.start_mark.line for node in pairs[at][1].value]
    items = []
    for i, content_line in enumerate(starts):
        first = _dash_line(lines, content_line)
        stop = _dash_line(lines, starts[i + 1]) if i + 1 < len(starts) else end
        last = stop - 1
        while last > content_line and _blank_or_comment(lines[last]):
            last -= 1
        items.append(KeyframeItem(first, last, content_line, lines[first].index("-")))
    return tuple(items)


def _dash_line(lines: list[str], content_line: int) -> int:
    line = content_line
    while line > 0 and not lines[line].lstrip().startswith("-"):
        line -= 1
    return line


def _blank_or_comment(line: str) -> bool:
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def number(value: float, decimals: int = DECIMALS) -> int | float:
    """``value`` rounded as the file gets it: whole numbers without a decimal point."""
    rounded = round(float(value), decimals) + 0.0  # + 0.0: no "-0.0"
    return int(rounded) if rounded.is_integer() else rounded


def pose_mapping(pose_deg: Mapping[str, float]):
    comments = require("ruamel.yaml.comments")
    pose = comments.CommentedMap((name, number(v)) for name, v in pose_deg.items())
    pose.fa.set_flow_style()
    return pose


def _flow_numbers(values: Sequence[float] | np.ndarray):
    comments = require("ruamel.yaml.comments")
    seq = comments.CommentedSeq(number(v) for v in values)
    seq.fa.set_flow_style()
    return seq


def sites_mapping(site: str, at_mm: Sequence[float] | np.ndarray, pitch_deg: float | None = None):
    """``{site: {at: [x, y, z]}}`` (with ``pitch`` where given) in flow style, millimetres and
    degrees to the tenth."""
    comments = require("ruamel.yaml.comments")
    target = comments.CommentedMap(at=_flow_numbers(at_mm))
    if pitch_deg is not None:
        target["pitch"] = number(pitch_deg)
    target.fa.set_flow_style()
    sites = comments.CommentedMap([(site, target)])
    sites.fa.set_flow_style()
    return sites


def body_mapping(pose: BodyPose):
    """``{x: .., z: .., roll: ..}`` in flow style: the fields that are not 0 (mm and degrees
    to the tenth), as a ``body:`` keyframe is written; ``{z: 0}`` for the pose it stood in."""
    comments = require("ruamel.yaml.comments")
    values = {
        "x": pose.x_mm,
        "y": pose.y_mm,
        "z": pose.z_mm,
        "roll": pose.roll_deg,
        "pitch": pose.pitch_deg,
        "yaw": pose.yaw_deg,
    }
    body = comments.CommentedMap((k, number(v)) for k, v in values.items() if number(v) != 0)
    if not body:
        body["z"] = 0
    body.fa.set_flow_style()
    return body


def _item_text(item: Any, dash_col: int) -> list[str]:
    out = io.StringIO()
    _yaml().dump([item], out)
    lines = out.getvalue().splitlines()
    return [(" " * dash_col + line).rstrip() if line else line for line in lines]


Ending = tuple[str, str]  # the file's line ending, and what ends its last line ("" or that)


def _lines(text: str) -> tuple[list[str], Ending]:
    """``text``'s lines, and how they end (a file written on Windows keeps its CRLF)."""
    newline = "\r\n" if "\r\n" in text else "\n"
    return text.splitlines(), (newline, newline if text.endswith("\n") or not text else "")


def _joined(lines: list[str], ending: Ending) -> str:
    newline, last = ending
    return newline.join(lines) + last


def add_keyframe(
    text: str, after: int | None, key: str, value: Any, timing: Mapping[str, float]
) -> str:
    """Insert ``key: value`` (``pose:``, ``sites:`` or ``body:``) timed by ``timing`` (``{"t":
    1.5}``, ``{"after": 0.4}``, ``{"bar": 5, "beat": 3}``) after the ``after``-th keyframe item
    (``None``: first in the list)."""
    comments = require("ruamel.yaml.comments")
    items = keyframe_items(text)
    lines, ending = _lines(text)
    if not items:
        raise EditRefused("the keyframes: list is empty or written in flow style: add one by hand")
    item = comments.CommentedMap()
    item[key] = value
    item.update(timing)
    if after is None:
        at, dash_col = items[0].first_line, items[0].dash_col
    else:
        at, dash_col = items[after].last_line + 1, items[after].dash_col
    return _joined(lines[:at] + _item_text(item, dash_col) + lines[at:], ending)


def _rewrite_item(
    text: str, index: int, where: str, values: Mapping[str, Any], replaces: tuple[str, ...]
) -> str:
    """The ``index``-th keyframe item with each ``key: value`` of ``values`` written, and the
    keys of ``replaces`` not among them dropped. A key whose value is already the one written
    keeps its text; a changed one keeps its place and its line's comment; a new one takes the
    place of the first key dropped, or goes under the others. Every other line stays."""
    item_lines = keyframe_items(text)[index]
    entry = _entry(text, index)
    lines, ending = _lines(text)
    if not isinstance(entry, require("ruamel.yaml.comments").CommentedMap) or entry.fa.flow_style():
        raise EditRefused(f"{where}: a keyframe written on one line in braces: edit it in the text")
    if "include" in entry or "gait" in entry:
        raise EditRefused(f"{where}: an include or gait block: edit it in the text")
    keys = list(entry)
    spans = _key_spans(entry, keys, lines, item_lines.last_line)
    dropped = [k for k in keys if k in replaces and k not in values]
    changed = [k for k in values if k in entry and not _same(entry[k], values[k])]
    added = [k for k in values if k not in entry]
    for k in dropped + changed:
        _check_no_anchor(entry, k, lines, where)
    edits: list[tuple[int, int, list[str]]] = []  # (first, last, lines): replace first..last
    for k in changed:
        first, last = spans[k]
        line, col = entry.lc.key(k)
        new = _value_lines(k, values[k], lines[line][:col])
        new[-1] += _trailing_comment(lines[last])
        edits.append((first, last, new))
    new_lines = []
    for k in added:
        prefix = " " * entry.lc.key(keys[-1])[1]
        new_lines += _value_lines(k, values[k], prefix)
    for k in dropped:
        first, last = spans[k]
        if new_lines:  # the new keys take the first dropped key's place (and its "- ")
            line, col = entry.lc.key(k)
            new_lines[0] = lines[line][:col] + new_lines[0][col:]
            new_lines[-1] += _trailing_comment(lines[last])
        edits.append((first, last, new_lines))
        new_lines = []
    if new_lines:
        under = max(last for _, last in spans.values())
        edits.append((under + 1, under, new_lines))
    out = list(lines)
    for first, last, new in sorted(edits, key=lambda e: e[0], reverse=True):
        out[first : last + 1] = new
    return _joined(out, ending)


def _same(written: Any, value: Any) -> bool:
    """Whether ``value`` is what the file already says (then its text is kept as written)."""
    try:
        return bool(written == value)
    except (TypeError, ValueError):  # numpy arrays and the like: not what a file holds
        return False


def _key_spans(entry: Any, keys: list, lines: list[str], item_last: int) -> dict:
    """Each key's lines (first, last) in the file: to the next key, comments left out."""
    starts = [entry.lc.key(k)[0] for k in keys]
    spans = {}
    for i, k in enumerate(keys):
        last = starts[i + 1] - 1 if i + 1 < len(keys) else item_last
        while last > starts[i] and _blank_or_comment(lines[last]):
            last -= 1
        spans[k] = (starts[i], last)
    return spans


def _check_no_anchor(entry: Any, key: str, lines: list[str], where: str) -> None:
    value_line, value_col = entry.lc.value(key)
    if lines[value_line][value_col:].startswith("*"):
        raise EditRefused(
            f"{where}: its {key} is another keyframe's (a YAML alias): edit it in the text"
        )
    if getattr(getattr(entry[key], "anchor", None), "value", None):
        raise EditRefused(
            f"{where}: other keyframes use its {key} (a YAML anchor): edit it in the text"
        )


def _trailing_comment(line: str) -> str:
    """``"  # row 2"`` of ``"    after: 0.5  # row 2"`` (keys and values here hold no "#")."""
    found = re.search(r"\s+#.*$", line)
    return found.group(0) if found else ""


def _value_lines(key: str, value: Any, prefix: str) -> list[str]:
    yaml = _yaml()
    yaml.width = max(40, yaml.width - len(prefix))
    out = io.StringIO()
    yaml.dump({key: value}, out)
    first, *rest = out.getvalue().splitlines()  # a wrapped flow line ends in a space: not kept
    return [(prefix + first).rstrip()] + [(" " * len(prefix) + line).rstrip() for line in rest]


def update_keyframe(text: str, index: int, where: str, key: str, value: Any) -> str:
    """The ``index``-th keyframe item's pose (or sites, or body) become ``key: value``; its
    timing stays. A joint pose or a body pose (whose legs are solved whole) replaces sites, body
    and any pose; sites replace only sites."""
    replaces = ("sites",) if key == "sites" else SPACE_KEYS + ("pose",)
    return _rewrite_item(text, index, where, {key: value}, replaces)


def update_pose(
    text: str, index: int, where: str, changed_deg: Mapping[str, float], whole: Mapping[str, float]
) -> str:
    """The ``index``-th keyframe item's joints of ``changed_deg`` take their new angles. In a
    pose written as a mapping only those change (every other joint stays as written); a
    named pose, sites or a body pose become the joint pose ``whole`` (with the changes)."""
    entry = _entry(text, index)
    written = entry.get("pose") if entry is not None else None
    comments = require("ruamel.yaml.comments")
    if isinstance(written, comments.CommentedMap):
        pose = comments.CommentedMap(written)
        for name, angle in changed_deg.items():
            pose[name] = number(angle)
        if written.fa.flow_style():
            pose.fa.set_flow_style()
        return update_keyframe(text, index, where, "pose", pose)
    return update_keyframe(text, index, where, "pose", pose_mapping({**whole, **changed_deg}))


def update_site(
    text: str, index: int, where: str, site: str, at_mm: Sequence[float] | np.ndarray
) -> str:
    """The ``index``-th keyframe item's ``site`` goes ``at_mm``; its orientation (``pitch``,
    ``frame``) and the other sites stay as written. Sites written where there were none (a
    pose, a body) are added beside it."""
    entry = _entry(text, index)
    comments = require("ruamel.yaml.comments")
    written = entry.get("sites") if entry is not None else None
    if not isinstance(written, comments.CommentedMap):
        return update_keyframe(text, index, where, "sites", sites_mapping(site, at_mm))
    sites = comments.CommentedMap(written)
    if written.fa.flow_style():
        sites.fa.set_flow_style()
    target = written.get(site)
    if isinstance(target, comments.CommentedMap):
        moved = comments.CommentedMap(target)
        if target.fa.flow_style():
            moved.fa.set_flow_style()
        moved["at"] = _flow_numbers(at_mm)
        sites[site] = moved
    else:
        sites[site] = sites_mapping(site, at_mm)[site]
    return update_keyframe(text, index, where, "sites", sites)


def _entry(text: str, index: int) -> Any:
    """The ``index``-th keyframe item as ruamel.yaml reads it round trip, its marks at the
    file's lines and columns: the item's lines alone are read (a whole long file costs
    seconds), or the whole file where the item names another's anchor."""
    item = keyframe_items(text)[index]
    lines = text.splitlines()
    alone = "\n" * item.first_line + "\n".join(lines[item.first_line : item.last_line + 1])
    try:
        entry = _yaml().load(alone)[0]
    except require("ruamel.yaml").YAMLError:  # an alias of an anchor outside the item
        entry = _yaml().load(text)["keyframes"][index]
    return entry if isinstance(entry, Mapping) else None


def retime_keyframe(text: str, index: int, where: str, timing: Mapping[str, float]) -> str:
    """The ``index``-th keyframe item arrives as ``timing`` says (``{"t": 1.5}``, ``{"after":
    0.4}``, ``{"beat": 9}``, ``{"bar": 3, "beat": 2}``), replacing whatever timed it (t, after,
    beat, bar); a value already written keeps its text."""
    return _rewrite_item(text, index, where, timing, TIMING_KEYS)


def written_time(
    notation: str, t_s: float, leave_s: float | None, grid: BeatGrid | None
) -> dict[str, int | float]:
    """How a keyframe at file time ``t_s`` is timed in ``notation``: ``t``; ``after`` (the
    keyframe before it left at ``leave_s``); ``beat`` or ``bar`` (and beat in the bar) on the
    song's beats, where ``t_s`` is inside them. Where the notation cannot say it (no keyframe
    before, outside the song), ``t``."""
    if notation == "after" and leave_s is not None and t_s >= leave_s:
        return {"after": number(t_s - leave_s, TIME_DECIMALS)}
    beats = grid is not None and grid.beats and grid.beat_times_s[0] <= t_s <= grid.beat_times_s[-1]
    if notation in ("beat", "bar") and beats:
        assert grid is not None
        beat = number(grid.beat_at(t_s), BEAT_DECIMALS)
        if notation == "beat":
            return {"beat": beat}
        bar, within = grid.bar_and_beat(beat)
        if abs(within - round(within)) < 10**-BEAT_DECIMALS:
            within = round(within)
        return {"bar": bar} if within == 1 else {"bar": bar, "beat": number(within, BEAT_DECIMALS)}
    return {"t": number(t_s, TIME_DECIMALS)}


def delete_keyframe(text: str, index: int) -> str:
    items = keyframe_items(text)
    if len(items) == 1:
        raise EditRefused("a motion needs at least one keyframe: this is the last one")
    lines, ending = _lines(text)
    item = items[index]
    return _joined(lines[: item.first_line] + lines[item.last_line + 1 :], ending)
