"""choreo.preview.floor: an infinite floor drawn finite looks the same, and is left infinite where
it would not."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from paths import REPO

from choreo.preview import floor, render
from choreo.preview.gl import offscreen_backend
from choreo.preview.render import CameraPose, FrameRenderer

TONYPI_SCENE = REPO / "models" / "tonypi" / "scene.xml"


def scene(floor_xml: str, light: str = 'directional="true"') -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(
        f"""<mujoco>
          <asset>
            <texture type="2d" name="checks" builtin="checker" width="64" height="64"
              rgb1="0.2 0.3 0.4" rgb2="0.1 0.2 0.3"/>
            <material name="metres" texture="checks" texuniform="true" texrepeat="5 3"/>
            <material name="stretched" texture="checks" texrepeat="5 5"/>
          </asset>
          <worldbody>
            <light pos="0 0 1.5" dir="0 0 -1" {light}/>
            {floor_xml}
            <body><freejoint/><geom type="box" size="0.1 0.1 0.1" pos="0 0 0.1"/></body>
          </worldbody>
        </mujoco>"""
    )


def a_frame(model: mujoco.MjModel, monkeypatch, finite: bool) -> np.ndarray:
    """Tonypi standing at home, from the scene's own angle, the floor reaching the horizon."""
    if not finite:
        monkeypatch.setattr(render, "draw_infinite_planes_finite", lambda model: 0)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    camera = CameraPose((0.0, 0.0, 0.15), 0.8, 140.0, -20.0)
    with FrameRenderer(model, 160, 120, offscreen_backend()) as renderer:
        return renderer.render(data, camera, ("time", "0.00 s"), ("", "")).astype(int)


def test_the_floor_drawn_finite_looks_the_same_pixel_for_pixel(monkeypatch):
    infinite = a_frame(mujoco.MjModel.from_xml_path(str(TONYPI_SCENE)), monkeypatch, False)
    monkeypatch.undo()
    model = mujoco.MjModel.from_xml_path(str(TONYPI_SCENE))
    finite = a_frame(model, monkeypatch, True)
    assert model.geom("floor").size[0] > 0  # FrameRenderer drew it finite
    floor_seen = (finite[60:, :, 2] > finite[60:, :, 0] + 40).mean()
    assert floor_seen > 0.3  # the bluish checks fill most of the lower half
    assert np.abs(finite - infinite).max() <= 1  # rounding, nothing a viewer could see


def test_the_finite_floor_reaches_as_far_with_its_checks_in_phase():
    model = scene('<geom name="floor" type="plane" size="0 0 0.05" material="metres"/>')
    assert floor.draw_infinite_planes_finite(model) == 1
    half_x, half_y, spacing = model.geom("floor").size
    far = model.vis.map.zfar * model.stat.extent
    for half, repeat in ((half_x, 5), (half_y, 3)):
        assert (2.1 * far + 4 / repeat) / 2 <= half < (2.1 * far + 4 / repeat) / 2 + 2 / repeat
        assert round(half * repeat) % 2 == 1
        assert half * repeat == pytest.approx(round(half * repeat))
    assert spacing == pytest.approx(max(half_x, half_y) / floor.QUADS_PER_HALF)


def test_an_untextured_infinite_floor_is_drawn_finite_and_a_finite_one_kept():
    model = scene('<geom name="floor" type="plane" size="0 0 0.05"/>')
    assert floor.draw_infinite_planes_finite(model) == 1
    assert min(model.geom("floor").size[:2]) > 0
    model = scene('<geom name="floor" type="plane" size="2 3 0.1"/>')
    assert floor.draw_infinite_planes_finite(model) == 0
    assert model.geom("floor").size.tolist() == pytest.approx([2, 3, 0.1])


@pytest.mark.parametrize(
    "floor_xml, light",
    [
        # a texture stretched over the plane's size: finite, it would be stretched over metres
        ('<geom name="floor" type="plane" size="0 0 0.05" material="stretched"/>', None),
        # a spot light is lit per vertex: a coarse grid would show
        ('<geom name="floor" type="plane" size="0 0 0.05"/>', 'cutoff="30"'),
    ],
    ids=["stretched texture", "spot light"],
)
def test_a_floor_that_would_look_different_finite_stays_infinite(floor_xml, light):
    model = scene(floor_xml, *([light] if light else []))
    assert floor.draw_infinite_planes_finite(model) == 0
    assert model.geom("floor").size.tolist() == pytest.approx([0, 0, 0.05])


def test_the_high_quality_renderer_keeps_the_infinite_floor():
    """Its haze shows the far edge, its reflection and multisampling a few pixels on the grid."""
    model = scene('<geom name="floor" type="plane" size="0 0 0.05" material="metres"/>')
    with FrameRenderer(model, 32, 32, offscreen_backend(), high_quality=True):
        assert model.geom("floor").size.tolist() == pytest.approx([0, 0, 0.05])
    with FrameRenderer(model, 32, 32, offscreen_backend()):
        assert min(model.geom("floor").size[:2]) > 0


def test_only_the_high_quality_renderer_allocates_a_shadow_map():
    """A preview draws no shadows: its 4096² map would cost 64 MB and ~0.04 s a context."""
    model = scene('<geom name="floor" type="plane" size="0 0 0.05" material="metres"/>')
    assert model.vis.quality.shadowsize == 4096
    with FrameRenderer(model, 32, 32, offscreen_backend(), high_quality=True):
        assert model.vis.quality.shadowsize == 4096
    with FrameRenderer(model, 32, 32, offscreen_backend()):
        assert model.vis.quality.shadowsize == 1
