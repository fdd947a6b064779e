"""choreo mirror: left for right with the robot's mirror pairs, timing and structure kept."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from choreo.cli import main
from choreo.errors import SourceError
from choreo.motion.mirror import mirrored_keyframes
from choreo.motion.motion_file import load_motion

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
ARM6 = REPO / "motions" / "arm6"


def mirror(source: Path, out: Path) -> Path:
    assert main(["mirror", str(source), "-o", str(out)]) == 0
    return out


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


def test_a_mirrored_arm6_wave_validates_and_turns_yaw_and_roll_the_other_way(tmp_path, capsys):
    """arm6 mirrors base_yaw and wrist_roll with sign -1; wave_block turns to 60° and rolls the
    hand to -30° first, and faces forward again at the end."""
    out = mirror(ARM6 / "wave.yaml", tmp_path / "wave_mirrored.yaml")
    assert main(["validate", "--no-physics", str(out)]) == 0, capsys.readouterr().out
    block = load_motion(mirror(ARM6 / "wave_block.yaml", tmp_path / "block_mirrored.yaml"))
    names = block.robot.joint_names
    yaw, roll = names.index("base_yaw"), names.index("wrist_roll")
    assert [(k.targets_deg[yaw], k.targets_deg[roll]) for k in block.keyframes] == [
        (-60, 30)
    ] * 5 + [(0, 0)]
    assert main(["validate", "--no-physics", str(block.path)]) == 0, capsys.readouterr().out


def test_tonypi_wave_with_the_right_arm_becomes_a_wave_with_the_left(tmp_path, capsys):
    source = tmp_path / "wave.yaml"
    assert (
        main(
            [
                "import",
                "d6a",
                str(REPO / "tests" / "data" / "tonypi" / "wave.d6a"),
                "--robot",
                "tonypi",
                "-o",
                str(source),
            ]
        )
        == 0
    )
    motion = load_motion(mirror(source, tmp_path / "wave_left.yaml"))
    raised = dict(zip(motion.robot.joint_names, motion.keyframes[1].targets_deg))
    assert raised["left_shoulder_pitch"] == 122.88 and raised["right_shoulder_pitch"] == 0
    assert raised["left_elbow"] == 43.92 and raised["right_elbow"] == 18


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


def test_a_robot_without_mirror_pairs_is_an_error(tmp_path, capsys):
    models = tmp_path / "models" / "tiny"
    shutil.copytree(DATA / "models" / "tiny", models)
    robot_file = models / "robot.yaml"
    text = robot_file.read_text()
    robot_file.write_text(text[: text.index("mirror:")])
    source = tmp_path / "swing.yaml"
    source.write_text("robot: tiny\nkeyframes:\n  - pose: wave\n")
    assert main(["mirror", str(source), "-o", str(tmp_path / "out.yaml")]) == 1
    assert capsys.readouterr().err == (
        f"choreo: error: {robot_file}: robot 'tiny' has no mirror pairs, so {source} cannot be "
        f"mirrored; add 'mirror:' pairs to the robot\n"
    )
    assert not (tmp_path / "out.yaml").exists()


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
