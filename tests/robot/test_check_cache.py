"""choreo.robot.check_cache: a model check that passed is not run again for the same files;
any change to what it reads runs it again, and a problem is never remembered away."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from cli_helpers import REPO

import choreo.robot.model_check as model_check
from choreo.errors import SourceError
from choreo.robot.check_cache import check_key
from choreo.robot.robot_file import load_robot


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("CHOREO_CACHE_DIR", str(folder))
    return folder


@pytest.fixture
def checks(monkeypatch) -> list[Path]:
    """The MJCF of every model check that runs, in order."""
    ran: list[Path] = []
    real = model_check.check_model

    def counted(reader, mjcf_path, *args):
        ran.append(mjcf_path)
        return real(reader, mjcf_path, *args)

    monkeypatch.setattr(model_check, "check_model", counted)
    return ran


def copy_of(robot: str, tmp_path: Path) -> Path:
    """models/<robot> copied, to be changed; its robot.yaml."""
    folder = tmp_path / "models" / robot
    shutil.copytree(REPO / "models" / robot, folder)
    return folder / "robot.yaml"


def test_a_passed_check_is_not_run_again_and_gives_the_same_robot(cache, checks):
    first = load_robot(REPO / "models/hexapod18/robot.yaml")
    again = load_robot(REPO / "models/hexapod18/robot.yaml")
    assert checks == [REPO / "models/hexapod18/hexapod18.xml"]
    assert again == first and again.free_floating is True
    fixed = load_robot(REPO / "models/arm6/robot.yaml")
    assert load_robot(REPO / "models/arm6/robot.yaml") == fixed
    assert fixed.free_floating is False and len(checks) == 2
    assert len(list((cache / "model-checks").iterdir())) == 2


def test_the_same_files_in_another_folder_find_the_check_passed(cache, checks, tmp_path):
    """As a performer finds it, staging each part's robot in a folder of its own."""
    first = load_robot(copy_of("arm6", tmp_path / "one"))
    again = load_robot(copy_of("arm6", tmp_path / "two"))
    assert len(checks) == 1 and again.free_floating is first.free_floating is False


def test_a_changed_model_is_checked_again_and_its_problem_reported(cache, checks, tmp_path):
    path = copy_of("arm6", tmp_path)
    load_robot(path)
    mjcf = path.with_name("arm6.xml")
    mjcf.write_text(mjcf.read_text().replace('name="home"', 'name="rest"'))
    with pytest.raises(SourceError, match="has no 'home' keyframe"):
        load_robot(path)
    with pytest.raises(SourceError, match="has no 'home' keyframe"):  # not remembered
        load_robot(path)
    assert len(checks) == 3


def test_a_changed_robot_file_is_checked_again(cache, checks, tmp_path):
    path = copy_of("arm6", tmp_path)
    load_robot(path)
    path.write_text(path.read_text().replace("name: arm6", "name: arm6  # the same arm"))
    load_robot(path)
    assert len(checks) == 2


def test_a_robot_file_with_a_problem_is_checked_whatever_was_remembered(cache, checks, tmp_path):
    path = copy_of("arm6", tmp_path)
    load_robot(path)
    mjcf = path.with_name("arm6.xml")
    mjcf.write_text(mjcf.read_text().replace('name="home"', 'name="rest"'))
    path.write_text(path.read_text().replace("name: arm6", "name: arm7"))
    with pytest.raises(SourceError) as caught:
        load_robot(path)
    [name, home] = caught.value.problems
    assert "must equal the robot's folder name 'arm6'" in name
    assert "has no 'home' keyframe" in home


def test_any_file_of_the_model_folders_is_part_of_the_key(tmp_path):
    path = copy_of("arm6", tmp_path)
    models = [path.with_name("arm6.xml"), path.with_name("scene.xml")]
    key = check_key(path, models)
    assert key is not None and check_key(path, models) == key
    mesh = path.parent / "assets" / "link.stl"
    mesh.parent.mkdir()
    mesh.write_bytes(b"solid")
    with_mesh = check_key(path, models)
    assert with_mesh not in (None, key)
    os.utime(mesh, ns=(0, 0))  # a mesh is known by size and time of change
    assert check_key(path, models) not in (None, key, with_mesh)


@pytest.mark.parametrize("named", ["../shared/arm.stl", "/meshes/arm.stl", "C:/arm.stl"])
def test_a_model_naming_a_file_outside_its_folders_is_not_remembered(named, tmp_path):
    path = copy_of("arm6", tmp_path)
    mjcf = path.with_name("arm6.xml")
    mjcf.write_text(
        mjcf.read_text().replace("<worldbody>", f'<asset><mesh file="{named}"/></asset><worldbody>')
    )
    assert check_key(path, [mjcf]) is None


def test_a_cache_that_cannot_be_written_only_costs_the_check(tmp_path, monkeypatch, checks):
    blocked = tmp_path / "a file"
    blocked.write_text("")
    monkeypatch.setenv("CHOREO_CACHE_DIR", str(blocked))
    first = load_robot(REPO / "models/arm6/robot.yaml")
    assert load_robot(REPO / "models/arm6/robot.yaml") == first
    assert len(checks) == 2


def test_the_cache_folder_follows_xdg_then_home(tmp_path, monkeypatch, checks):
    monkeypatch.delenv("CHOREO_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    load_robot(REPO / "models/arm6/robot.yaml")
    assert len(list((tmp_path / "xdg/choreo/model-checks").iterdir())) == 1
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    load_robot(REPO / "models/arm6/robot.yaml")
    assert len(list((tmp_path / "home/.cache/choreo/model-checks").iterdir())) == 1
    assert len(checks) == 2
