"""What the timeline's page asks the studio: its posted JSON read into a ``Request``, and a
request it should not have sent refused with one line (``RequestError``)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

OPS = ("scrub", "play", "select", "finding", "move", "delete", "add", "paste", "undo", "redo")


class RequestError(ValueError):
    """A request the timeline's page should not have sent: one line that says what is wrong."""


@dataclass(frozen=True)
class Placed:
    """A keyframe asked for at a time: moved there (``index``) or pasted there (``pose``)."""

    t_s: float
    index: int | None = None
    pose: Mapping[str, float] | None = None


@dataclass(frozen=True)
class Request:
    """What the timeline's page asks the studio; ``version`` is the state it saw (the reload
    its keyframe indices refer to), None for requests that name no keyframe."""

    op: str
    t_s: float | None = None
    indices: tuple[int, ...] = ()
    placed: tuple[Placed, ...] = ()
    version: int | None = None


def parse_request(body: bytes) -> Request:
    """The page's posted JSON as a ``Request``; ``RequestError`` if it is not one."""
    try:
        data = json.loads(body)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RequestError(f"a request that is not JSON: {error}") from None
    if not isinstance(data, dict) or data.get("op") not in OPS:
        raise RequestError(f"a request needs an op, one of {', '.join(OPS)}")
    op = data["op"]
    version = data.get("version")
    if version is not None and not _is_int(version):
        raise RequestError(f"{op}: version {version!r} is not a whole number")
    t = data.get("t")
    if op == "scrub" and not _is_number(t):
        raise RequestError(f"scrub: t {t!r} is not a number of seconds")
    indices = data.get("indices", [])
    if not isinstance(indices, list) or not all(_is_int(i) and i >= 0 for i in indices):
        raise RequestError(f"{op}: indices {indices!r} are not keyframe numbers")
    if op == "finding" and not _is_int(data.get("index")):
        raise RequestError(f"finding: index {data.get('index')!r} is not a finding's number")
    if op == "finding":
        indices = [data["index"]]
    placed: tuple[Placed, ...] = ()
    if op == "move":
        placed = tuple(_placed(op, m, "index") for m in _list(op, data, "moves"))
    elif op == "paste":
        placed = tuple(_placed(op, k, "pose") for k in _list(op, data, "keyframes"))
    t_s = float(t) if isinstance(t, int | float) and _is_number(t) else None
    return Request(op, t_s, tuple(indices), placed, version)


def _list(op: str, data: dict, key: str) -> list:
    items = data.get(key)
    if not isinstance(items, list) or not items:
        raise RequestError(f"{op}: {key} is not a list of keyframes")
    return items


def _placed(op: str, item: Any, key: str) -> Placed:
    if not isinstance(item, dict) or not _is_number(item.get("t")):
        raise RequestError(f"{op}: {item!r} has no time t")
    if key == "index":
        if not _is_int(item.get("index")) or item["index"] < 0:
            raise RequestError(f"move: {item!r} names no keyframe index")
        return Placed(float(item["t"]), index=item["index"])
    pose = item.get("pose")
    if not isinstance(pose, dict) or not all(
        isinstance(k, str) and _is_number(v) for k, v in pose.items()
    ):
        raise RequestError(f"paste: {item!r} has no pose of joint angles")
    return Placed(float(item["t"]), pose={k: float(v) for k, v in pose.items()})


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
