"""A robot's MuJoCo model compiled once per process: each caller gets its own copy, compiled
again only when the file, or an MJCF file it includes, has changed.

The same files are compiled over and over in one process: the robot file's checks, IK, the
preview's physics, its checks and its renders each load the model, and a scene takes ~30 ms to
compile (most of it drawing the skybox's texture), against ~3 ms to copy the compiled model.
A copy, because callers change their model (the preview sets the servos' figures on it).

What a file compiles to is known by its text and the text of the MJCF files it includes
(``<include file=...>``, each found from the first file's folder as MuJoCo finds it): an edit
to any of them is compiled afresh. Meshes and textures read from files are not watched (the
studio, which reloads a robot when its files change, watches the MJCF and the scene alone too).

MuJoCo's warnings go to choreo's log from the moment this module is imported (every model choreo
simulates or draws is compiled here). Left to itself, MuJoCo prints each one on stderr and adds
it to a MUJOCO_LOG.TXT in whatever folder the user is in; choreo reports what matters of them in
its own words (an unstable simulation is an error naming the joint, from MuJoCo's counters).
"""

from __future__ import annotations

import copy
import hashlib
import logging
import re
import threading
from collections import OrderedDict
from pathlib import Path

import mujoco

KEPT = 8  # compiled models kept (a scene with its skybox is ~5 MB)
_INCLUDE = re.compile(rb"<include\s+file\s*=\s*[\"']([^\"']+)[\"']")
_compiled: OrderedDict[tuple[Path, bytes], mujoco.MjModel] = OrderedDict()
_lock = threading.Lock()  # the studio loads models from more than one thread
log = logging.getLogger(__name__)


def _log_mujoco_warning(message: str) -> None:
    log.debug("MuJoCo: %s", message)


mujoco.set_mju_user_warning(_log_mujoco_warning)


def compiled_model(path: str | Path) -> mujoco.MjModel:
    """MuJoCo's model of the MJCF file at ``path``, the caller's own to change. A file MuJoCo
    cannot compile raises its ValueError, as ``MjModel.from_xml_path`` does (every time)."""
    path = Path(path).resolve()
    try:
        key = (path, _sources_digest(path))
    except OSError:
        return mujoco.MjModel.from_xml_path(str(path))  # MuJoCo's own error for it
    with _lock:
        model = _compiled.get(key)
        if model is None:
            model = _compiled[key] = mujoco.MjModel.from_xml_path(str(path))
            if len(_compiled) > KEPT:
                _compiled.popitem(last=False)
        _compiled.move_to_end(key)
        return copy.copy(model)  # MjModel's copy is a deep one: its arrays are copied


def _sources_digest(path: Path) -> bytes:
    """A digest of the text of ``path`` and of every file it includes, recursively."""
    digest, folder = hashlib.blake2b(digest_size=16), path.parent
    pending, seen = [path], set()
    while pending:
        source = pending.pop()
        if source in seen:  # (MuJoCo refuses a file included twice; it says so itself)
            continue
        seen.add(source)
        text = source.read_bytes()
        digest.update(str(source).encode() + b"\0" + text + b"\0")
        pending.extend(folder / name.decode() for name in _INCLUDE.findall(text))
    return digest.digest()
