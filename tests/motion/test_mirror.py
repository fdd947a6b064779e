"""choreo mirror: left for right with the robot's mirror pairs, timing and structure kept."""

from __future__ import annotations

import pytest
from cli_helpers import mirror
from paths import DATA, REPO

from choreo.errors import SourceError
from choreo.motion.mirror import mirrored_keyframes
from choreo.motion.motion_file import load_motion

ARM6 = REPO / "motions" / "arm6"


def timing(keyframe) -> tuple:
    return keyframe.t_s, keyframe.after_s, keyframe.hold_s, keyframe.stop, keyframe.velocity_scale


@pytest.mark.parametrize(
    "source",
    [
        ARM6 / "wave_both_ways.yaml",
        ARM6 / "dance.yaml",
        ARM6 / "pick_and_place.yaml",
        REPO / "motions" / "hexapod18" / "tripod_gait.yaml",
        REPO / "motions" / "tonypi" / "left_kick.yaml",
    ],
    ids=lambda p: f"{p.parent.name}/{p.stem}",
)
def test_mirroring_twice_gives_back_the_original(source, tmp_path):
    original = load_motion(source)
    once = load_motion(mirror(source, tmp_path / "once.yaml"))
    twice = load_motion(mirror(tmp_path / "once.yaml", tmp_path / "twice.yaml"))
    assert [k.targets_deg for k in twice.keyframes] == [k.targets_deg for k in original.keyframes]
    assert [k.targets_deg for k in once.keyframes] != [k.targets_deg for k in original.keyframes]
    for motion in (once, twice):
        assert [timing(k) for k in motion.keyframes] == [timing(k) for k in original.keyframes]
        assert (motion.speed, motion.repeat) == (original.speed, original.repeat)


def test_timing_and_keyframe_options_are_kept(tmp_path):
    source = tmp_path / "timed.yaml"
    source.write_text(
        "robot: arm6\nspeed: 1.5\nrepeat: 2\ndescription: 'Timed: every option'\nkeyframes:\n"
        "  - pose: {base_yaw: 10}\n    after: 0.25\n"
        "  - pose: {base_yaw: -20, wrist_roll: 5}\n    t: 1.5\n    hold: 0.3\n"
        "  - pose: ready\n    after: 0.7\n    stop: true\n    velocity: 0.4\n"
        "  - pose: home\n    hold: 0.00001\n"
    )  # YAML 1.1 would read 1e-05 as a string
    out = mirror(source, tmp_path / "timed_mirrored.yaml")
    motion = load_motion(out)
    yaw = motion.robot.joint_names.index("base_yaw")
    assert [k.targets_deg[yaw] for k in motion.keyframes] == [-10, 20, 0, 0]
    assert [timing(k) for k in motion.keyframes] == [
        (None, 0.25, 0.0, False, 1.0),
        (1.5, None, 0.3, True, 1.0),
        (None, 0.7, 0.0, True, 0.4),
        (None, None, 0.00001, True, 1.0),
    ]
    assert (motion.speed, motion.repeat) == (1.5, 2)
    text = out.read_text()
    assert "  - pose: ready\n" in text and "  - pose: home\n" in text  # symmetric poses by name
    assert 'description: "Mirror image of timed: Timed: every option"' in text


def test_mirrored_angles_outside_the_partners_limits_are_reported(tmp_path):
    """tiny: left -60..120 and right -110..60, mirrored with sign -1: left 115 has no mirror
    image, left 90 / right -100 has one (right -90 / left 100)."""
    source = tmp_path / "reach.yaml"
    source.write_text(
        f"robot: {DATA / 'models' / 'tiny' / 'robot.yaml'}\nkeyframes:\n"
        "  - pose: home\n  - pose: {left: 115}\n    after: 1\n"
        "  - pose: {left: 90, right: -100}\n    after: 1\n"
        "  - pose: {left: 112}\n    after: 1\n"
    )
    with pytest.raises(SourceError) as error:
        mirrored_keyframes(load_motion(source))
    assert error.value.problems == [
        f"{source}:4:5: mirrored, right would be at -115°, outside its limits -110..60°",
        f"{source}:8:5: mirrored, right would be at -112°, outside its limits -110..60°",
    ]


def test_a_mirrored_pick_keeps_its_name_and_props_reflected_and_places_the_block(tmp_path):
    """The block is picked on the left and placed on the right; mirrored, it is picked on the
    right and placed on the left, and the preview finds it placed as it does the original."""
    from choreo.preview import run_checks, simulate_motion

    original = load_motion(ARM6 / "pick_and_place.yaml")
    mirrored = load_motion(mirror(ARM6 / "pick_and_place.yaml", tmp_path / "pick_left.yaml"))
    assert mirrored.name == original.name == "pick_and_place"
    (block,), (before,) = mirrored.props, original.props
    assert block.at_m == (before.at_m[0], -before.at_m[1], before.at_m[2])
    assert block.place_at_m == (before.place_at_m[0], -before.place_at_m[1], 0.0)
    assert (block.yaw_deg, block.size_m, block.mass_kg) == (-50, before.size_m, before.mass_kg)
    simulated = simulate_motion(mirrored)
    (outcome,) = simulated.props
    assert outcome.lifted and outcome.placed, outcome.line()
    assert [r for r in run_checks(simulated) if r.severity.value == "error"] == []


def test_a_mirrored_lie_down_keeps_its_start_and_end(tmp_path):
    source = DATA / "preview" / "motions" / "lie_down_declared.yaml"
    original = load_motion(source)
    mirrored = load_motion(mirror(source, tmp_path / "lie_down_mirrored.yaml"))
    assert (mirrored.start, mirrored.end) == (original.start, original.end)
    assert mirrored.end.lying
