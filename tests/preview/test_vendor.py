"""Every TonyPi action group from the vendor, imported with ``choreo import d6a`` and previewed
with ``choreo preview --check``: no false alarm. Those whose timing asks more than the joint limits
allow are stretched; the two that begin on the floor say so (``start:``), and climb_stairs gets
its step (``props:``), in a motion that includes the plain import."""

from __future__ import annotations

import re

import pytest
from paths import DATA

from choreo.cli import main
from choreo.motion.motion_file import load_motion
from choreo.preview import simulate_motion

VENDOR = DATA / "tonypi"
# rows the joint limits cannot reach in the vendor's time (test_d6a names each keyframe)
STRETCHED = {
    "go_forward",
    "go_forward_end",
    "go_forward_start",
    "sit_ups",
    "stand_up_front",
    "wave",
    "wing_chun",
}
# what the motion file adds around the import: the robot lying on its front or back, or the
# step climb_stairs climbs (the model's climb succeeds on steps up to about 2 cm)
WARNING = (
    r"near miss: .* \(moving up to \d+°/s of its \d+°/s|can't keep up: .* while moving"
    r"|off its commanded path .* for 0\.0\d s|runs into its (min|max) limit"
)
SCENES = {
    "stand_up_front": "start: lying_front\n",
    "sit_ups": "start: lying_back\n",
    "climb_stairs": "props:\n  - {name: step, size_m: [0.3, 0.4, 0.015], at_m: [0.2, 0, 0]}\n",
}


@pytest.mark.parametrize("source", sorted(VENDOR.glob("*.d6a")), ids=lambda p: p.stem)
def test_every_vendor_action_group_previews_without_an_error(source, tmp_path, capsys):
    imported = tmp_path / f"{source.stem}.yaml"
    assert main(["import", "d6a", str(source), "--robot", "tonypi", "-o", str(imported)]) == 0
    motion = imported
    if source.stem in SCENES:
        motion = tmp_path / f"{source.stem}_scene.yaml"
        motion.write_text(
            f"robot: tonypi\n{SCENES[source.stem]}keyframes:\n  - include: {imported.name}\n"
        )
    stretch = ["--stretch"] if source.stem in STRETCHED else []
    capsys.readouterr()
    code = main(["preview", "--check", str(motion), *stretch])
    out = capsys.readouterr().out
    assert code == 0, out
    assert " 0 error(s)" in out
    # warnings only of a servo near its limit or a short lag, each saying how it came about
    for line in out.splitlines():
        if ": warning: " in line:
            assert re.search(WARNING, line), line


def test_climb_stairs_really_climbs_its_step(tmp_path):
    imported = tmp_path / "climb_stairs.yaml"
    source = VENDOR / "climb_stairs.d6a"
    assert main(["import", "d6a", str(source), "--robot", "tonypi", "-o", str(imported)]) == 0
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        f"robot: tonypi\n{SCENES['climb_stairs']}keyframes:\n  - include: {imported.name}\n"
    )
    rollout = simulate_motion(load_motion(scene), stretch=True).rollout
    height = rollout.body.height_m
    assert height[-1] - height[rollout.start_step] == pytest.approx(0.015, abs=0.003)


def test_the_vendor_files_are_all_here():
    assert len(list(VENDOR.glob("*.d6a"))) == 15
