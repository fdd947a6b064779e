"""choreo.robot.lookup: a robot is named (searched in ``models`` folders: up from the naming file,
then $CHOREO_MODELS, then the repository's) or given by a path relative to the naming file."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from paths import DATA, REPO

from choreo.errors import SourceError
from choreo.robot.lookup import find_robot_file, is_robot_path, robot_search_dirs
from choreo.robot.robot_file import load_robot

TINY = DATA / "models" / "tiny" / "robot.yaml"
REPO_MODELS = REPO / "models"


def test_name_is_found_walking_up_from_the_naming_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the working directory must not matter
    robot = load_robot("tiny", relative_to=DATA / "motions" / "wave.yaml")
    assert robot.path.resolve() == TINY.resolve()


def test_name_is_found_through_choreo_models(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CHOREO_MODELS", str(DATA / "models"))
    assert load_robot("tiny").path.resolve() == TINY.resolve()


def test_path_is_relative_to_the_naming_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    robot = load_robot("../models/tiny", relative_to=DATA / "motions" / "wave.yaml")
    assert robot.path.resolve() == TINY.resolve()


def test_shipped_robot_found_by_name_from_anywhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("CHOREO_MODELS", raising=False)
    hexapod = load_robot("hexapod18")  # from the repository's models/
    assert hexapod.path == REPO / "models/hexapod18/robot.yaml"
    assert hexapod.free_floating is True and len(hexapod.joints) == 18


def test_unknown_name_lists_the_known_robots(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SourceError) as caught:
        load_robot("tinny", relative_to=DATA / "motions" / "wave.yaml")
    message = str(caught.value)
    assert message.startswith("unknown robot 'tinny' (did you mean 'tiny'?); known robots: ")
    assert "tiny" in message.split("known robots: ")[1]
    assert str((DATA / "models").resolve()) in message  # says where it looked


@pytest.mark.parametrize(
    "ref, is_path",
    [("arm6", False), ("models/arm6", True), ("robot.yaml", True), ("x.yml", True)]
    + [(Path("arm6"), True)],
)
def test_a_folder_part_or_a_yaml_ending_makes_a_path(ref, is_path):
    assert is_robot_path(ref) is is_path


def test_the_search_goes_up_then_choreo_models_then_the_repository(tmp_path, monkeypatch):
    inner = tmp_path / "a" / "b"
    for folder in (tmp_path / "models", tmp_path / "a" / "models", inner, tmp_path / "extra"):
        folder.mkdir(parents=True, exist_ok=True)
    monkeypatch.setenv("CHOREO_MODELS", os.pathsep.join([str(tmp_path / "extra"), ""]))
    assert robot_search_dirs(inner)[:3] == [
        (tmp_path / "a" / "models").resolve(),
        (tmp_path / "models").resolve(),
        (tmp_path / "extra").resolve(),
    ]
    assert robot_search_dirs(inner)[-1] == REPO_MODELS.resolve()


def test_a_nearer_robot_hides_a_farther_one_of_the_same_name(tmp_path, monkeypatch):
    monkeypatch.delenv("CHOREO_MODELS", raising=False)
    own = tmp_path / "models" / "arm6" / "robot.yaml"
    own.parent.mkdir(parents=True)
    own.write_text("name: arm6\n")
    assert find_robot_file("arm6", relative_to=tmp_path / "wave.yaml") == own.resolve()


def test_a_path_to_nothing_says_where_it_looked(tmp_path):
    with pytest.raises(LookupError) as raised:
        find_robot_file("../nowhere", relative_to=tmp_path / "m.yaml")
    expected = os.path.normpath(tmp_path / "../nowhere")
    assert str(raised.value) == f"robot file '../nowhere' not found (looked for {expected})"
