"""choreo.robot.compiled_model: a model compiled once per process, each caller given a copy."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from paths import REPO

from choreo.preview.model import model_digest
from choreo.robot.compiled_model import compiled_model

ROBOT = """<mujoco model="{name}"><worldbody><body name="link"><joint name="j" type="hinge"/>
<geom type="box" size="{size} 0.01 0.01"/></body></worldbody></mujoco>"""
SCENE = """<mujoco><include file="robot.xml"/>
<worldbody><geom type="plane" size="1 1 1"/></worldbody></mujoco>"""


def link_length(model: mujoco.MjModel) -> float:
    return float(model.geom_size[model.body("link").geomadr[0], 0])


def test_each_caller_gets_its_own_copy_of_what_mujoco_compiles():
    scene = REPO / "models" / "arm6" / "scene.xml"
    first, second = compiled_model(scene), compiled_model(scene)
    assert first is not second
    fresh = mujoco.MjModel.from_xml_path(str(scene))
    assert model_digest(first) == model_digest(fresh)
    np.testing.assert_array_equal(first.tex_data, fresh.tex_data)  # (the digest leaves it out)
    first.actuator_gainprm[0, 0] = 99.0
    first.opt.timestep = 0.5
    assert model_digest(compiled_model(scene)) == model_digest(second) == model_digest(fresh)


@pytest.mark.parametrize("edited", ["scene.xml", "robot.xml"])
def test_an_edit_to_the_file_or_one_it_includes_is_compiled_afresh(tmp_path, edited):
    (tmp_path / "robot.xml").write_text(ROBOT.format(name="r", size=0.05))
    (tmp_path / "scene.xml").write_text(SCENE)
    before = compiled_model(tmp_path / "scene.xml")
    assert (before.ngeom, link_length(before)) == (2, pytest.approx(0.05))
    if edited == "robot.xml":  # the same length: only the text tells it changed
        (tmp_path / "robot.xml").write_text(ROBOT.format(name="r", size=0.07))
    else:
        (tmp_path / "scene.xml").write_text(
            SCENE.replace("</worldbody>", "<geom size='.1'/></worldbody>")
        )
    after = compiled_model(tmp_path / "scene.xml")
    assert (after.ngeom, link_length(after)) == (
        (2, pytest.approx(0.07)) if edited == "robot.xml" else (3, pytest.approx(0.05))
    )


def test_a_file_mujoco_cannot_compile_raises_its_error_every_time(tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>")
    for _ in range(2):
        with pytest.raises(ValueError):
            compiled_model(broken)
    (tmp_path / "scene.xml").write_text(SCENE)  # includes a robot.xml that is not there
    with pytest.raises(ValueError):
        compiled_model(tmp_path / "scene.xml")
    with pytest.raises(ValueError):
        compiled_model(tmp_path / "absent.xml")


def test_mujocos_warnings_go_to_the_log_not_to_stderr_or_a_file_in_the_users_folder(
    tmp_path, monkeypatch, capfd, caplog
):
    (tmp_path / "robot.xml").write_text(ROBOT.format(name="r", size=0.05))
    model = compiled_model(tmp_path / "robot.xml")
    monkeypatch.chdir(tmp_path)
    data = mujoco.MjData(model)
    data.qvel[:] = 1e30  # MuJoCo warns of it, and resets the state
    with caplog.at_level("DEBUG", logger="choreo.robot.compiled_model"):
        mujoco.mj_step(model, data)
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number == 1  # still counted
    assert "huge value in QVEL" in caplog.text
    assert capfd.readouterr().err == ""
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
