"""The contacts of a simulation worth reporting, logged step by step into ``Contacts``: pairs are
classified (self, floor, neighbour, ground, foot, held) only when they change."""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import mujoco
import numpy as np

from choreo.preview.model import (
    FLOOR_CONTACT,
    FOOT_CONTACT,
    GROUND_CONTACT,
    HELD_CONTACT,
    NEIGHBOUR_CONTACT,
    NO_CONTACT,
    SELF_CONTACT,
    contact_kinds,
    free_joint,
    geom_labels,
)
from choreo.preview.rollout import ContactPair, Contacts

CONTACT_NAMES = {
    SELF_CONTACT: "self",
    FLOOR_CONTACT: "floor",
    NEIGHBOUR_CONTACT: "neighbour",
    GROUND_CONTACT: "ground",
    FOOT_CONTACT: "foot",
    HELD_CONTACT: "held",
}


class ContactLog:
    """The contacts worth reporting, step by step. Most steps repeat the previous step's contact
    pairs (feet on the floor), so pairs are only classified when they change."""

    def __init__(self, model: mujoco.MjModel, min_depth_m: float, feet: Sequence[int] = ()):
        self._kinds = contact_kinds(model, free_floating=free_joint(model) is not None, feet=feet)
        self._labels = geom_labels(model)
        self._on_world = model.geom_bodyid == 0
        self._min_depth_m = min_depth_m
        self._last_pairs = b""
        # the pair each watched touch belongs to, and where the touch is in the contact list
        self._watched: list[tuple[int, str, str]] = []
        self._watched_at = np.zeros(0, dtype=int)
        self._all_watched = False  # every touch is watched: no need to pick them out
        self._watched_ids: list[int] | None = None  # their pairs' numbers, once all have one
        self._pair_ids: dict[tuple[int, str, str], int] = {}
        self._named_at: list[int] = []  # per pair: the entry that first named it (ascending)
        self.steps: list[int] = []
        self.pair_index: list[int] = []
        self.depths_m: list[float] = []

    def see(self, data: mujoco.MjData, step: int) -> None:
        contact = data.contact  # the step's touches (``data.ncon`` of them)
        geoms = contact.geom
        pairs = geoms.tobytes()
        if pairs != self._last_pairs:
            self._last_pairs = pairs
            watched = np.flatnonzero(self._kinds[geoms[:, 0], geoms[:, 1]] != NO_CONTACT)
            self._watched = [self._pair_key(*geoms[i]) for i in watched]
            self._watched_at = watched
            self._all_watched = len(watched) == len(geoms)
            self._watched_ids = None
        if not self._watched:
            return
        distances = contact.dist if self._all_watched else contact.dist[self._watched_at]
        depths = np.negative(distances).tolist()  # a handful: Python's min is quicker than numpy's
        minimum = self._min_depth_m
        if self._watched_ids is not None and min(depths) > minimum:
            # the usual step: the same touches as the last, every one deep enough (its depth,
            # minus its distance, over the minimum) and its pair numbered, logged at once (this
            # runs at every physics step)
            self.pair_index += self._watched_ids
            self.steps += [step] * len(self._watched_ids)
            self.depths_m += depths
            return
        for key, depth in zip(self._watched, depths):
            if depth > minimum:
                self.pair_index.append(self._pair_id(key))
                self.steps.append(step)
                self.depths_m.append(depth)
        if self._watched_ids is None and all(key in self._pair_ids for key in self._watched):
            self._watched_ids = [self._pair_ids[key] for key in self._watched]

    def _pair_id(self, key: tuple[int, str, str]) -> int:
        pair = self._pair_ids.get(key)
        if pair is None:
            pair = self._pair_ids[key] = len(self._pair_ids)
            self._named_at.append(len(self.steps))
        return pair

    def _pair_key(self, g1: int, g2: int) -> tuple[int, str, str]:
        """The pair's kind and names (the world's or a prop's second, else sorted), which are
        numbered as they are first recorded."""
        kind = int(self._kinds[g1, g2])
        a, b = self._labels[g1], self._labels[g2]
        if kind in (FLOOR_CONTACT, GROUND_CONTACT, FOOT_CONTACT):
            names = (b, a) if self._on_world[g1] else (a, b)
        else:
            names = (a, b) if a <= b else (b, a)  # sorted
        return (kind, *names)

    def take_from(self, other: ContactLog, entries: int) -> None:
        """``other``'s first ``entries`` contacts, and the pairs they name, as this log's."""
        pairs = bisect.bisect_left(other._named_at, entries)
        self._last_pairs = b""  # the pairs are numbered anew: the touches are classified anew
        self.steps = other.steps[:entries]
        self.pair_index = other.pair_index[:entries]
        self.depths_m = other.depths_m[:entries]
        self._pair_ids = dict(list(other._pair_ids.items())[:pairs])
        self._named_at = other._named_at[:pairs]

    def take_rest(self, other: ContactLog, entries: int) -> None:
        """``other``'s contacts from entry ``entries`` on, after this log's: its pairs numbered
        as this log numbers them (in the order they first touch), the new ones after."""
        self._last_pairs = b""  # new pairs may be numbered: the touches are classified anew
        rest = np.array(other.pair_index[entries:], dtype=int)
        keys = list(other._pair_ids)
        ours = np.zeros(len(keys), dtype=int)  # other's pair number -> ours
        seen, first = np.unique(rest, return_index=True)
        for theirs, at in sorted(zip(seen.tolist(), first.tolist()), key=lambda pair: pair[1]):
            pair = self._pair_ids.get(keys[theirs])
            if pair is None:
                pair = self._pair_ids[keys[theirs]] = len(self._pair_ids)
                self._named_at.append(len(self.steps) + at)
            ours[theirs] = pair
        self.steps += other.steps[entries:]
        self.pair_index += ours[rest].tolist()
        self.depths_m += other.depths_m[entries:]

    def recorded(self) -> Contacts:
        ordered = sorted(self._pair_ids, key=self._pair_ids.__getitem__)
        return Contacts(
            tuple(ContactPair(CONTACT_NAMES[kind], a, b) for kind, a, b in ordered),
            np.array(self.steps, dtype=int),
            np.array(self.pair_index, dtype=int),
            np.array(self.depths_m, dtype=float),
        )
