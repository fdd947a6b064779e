"""A part travels as files: the conductor packs a motion with every file it uses, the performer
unpacks them into a folder of its own (same layout) and loads the motion from there, so what a
robot dances is exactly what the conductor's files say, whatever is installed on its computer."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

from choreo.errors import ChoreoError
from choreo.motion.motion_file import Motion, load_motion
from choreo.show.messages import StagedPart


def used_files(motion: Motion) -> list[Path]:
    """The motion file, its includes, its robot's files and its song."""
    files = [motion.path]
    for keyframe in motion.keyframes:
        files += [keyframe.where.path, *(entry.path for entry in keyframe.where.included_at)]
    robot = motion.robot
    files += [p for p in (robot.path, robot.mjcf_path, robot.scene_path) if p is not None]
    if motion.music is not None:
        files.append(motion.music.song)
    unique: dict[Path, None] = dict.fromkeys(p.resolve() for p in files)
    return list(unique)


def pack(show_id: str, ticket: str, motion: Motion) -> StagedPart:
    files = used_files(motion)
    root = Path(os.path.commonpath([p.parent for p in files]))

    def relative(path: Path) -> str:
        return path.resolve().relative_to(root).as_posix()

    contents = {relative(p): p.read_bytes() for p in files}
    return StagedPart.of(
        show_id, ticket, relative(motion.path), relative(motion.robot.path), contents
    )


def unpack(part: StagedPart, folder: Path) -> Motion:
    """Write the part's files under ``folder`` and load its motion from there."""
    for name, data in part.contents().items():
        path = folder / _inside(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    robot_file = folder / _inside(part.robot_file)
    with _models_folder(robot_file.parent.parent):
        motion = load_motion(folder / _inside(part.motion))
    if motion.robot.path.resolve() != robot_file.resolve():
        raise ChoreoError(
            f"the staged motion found the robot {motion.robot.path} instead of the one sent "
            f"with it ({part.robot_file}); remove the other robot's models folder"
        )
    return motion


def _inside(name: str) -> PurePosixPath:
    """A relative path that stays inside the staging folder."""
    path = PurePosixPath(name)
    if path.is_absolute() or ".." in path.parts or not path.parts:
        raise ChoreoError(f"refusing a staged file outside the staging folder: {name!r}")
    return path


@contextlib.contextmanager
def _models_folder(folder: Path) -> Iterator[None]:
    """Robot names are also looked up in ``folder`` (the staged robot's) while loading."""
    previous = os.environ.get("CHOREO_MODELS")
    os.environ["CHOREO_MODELS"] = os.pathsep.join(p for p in (str(folder), previous) if p)
    try:
        yield
    finally:
        if previous is None:
            del os.environ["CHOREO_MODELS"]
        else:
            os.environ["CHOREO_MODELS"] = previous
