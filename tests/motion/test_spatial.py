"""Keyframes written in space (sites:, body:, gait:) as motion files: every IK keyframe of the
shipped motions checked with MuJoCo's forward kinematics; the messages for what cannot be done;
what `choreo validate` and `choreo plan --json` show."""

from __future__ import annotations

import functools
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from cli_helpers import error_line
from paths import DATA, REPO

from choreo.cli import main
from choreo.errors import SourceError
from choreo.motion.gait import BodyPose, Gait, Pattern, feet_under_body, gait_keyframes
from choreo.motion.motion_file import load_motion, most_gait_steps
from choreo.motion.spatial import compensated
from choreo.robot.kinematics import Kinematics
from choreo.robot.types import GaitCompensation

SHIPPED = sorted((REPO / "motions").glob("*/*.yaml"))
# the shipped tonypi motions are all vendor imports: its hands are placed by IK in a test motion
TEST_MOTIONS = sorted((DATA / "spatial").glob("*.yaml"))
POSITION_MM, ANGLE_DEG = 1.0, 1.0

_KINEMATICS: dict[str, Kinematics] = {}


def kinematics(motion) -> Kinematics:
    name = motion.robot.name
    if name not in _KINEMATICS:
        _KINEMATICS[name] = Kinematics(motion.robot)
    return _KINEMATICS[name]


@functools.cache  # asked at collection, then by the tests: the file is read once (not changed)
def spatial_items(path: Path) -> list[tuple[int, dict]]:
    """(line, item) of every keyframe list item with sites, body or gait."""
    root = yaml.compose(path.read_text(), Loader=yaml.CSafeLoader)  # at collection: libyaml
    items = []
    for key, value in root.value:
        if key.value == "keyframes":
            for node in value.value:
                item = yaml.load(yaml.serialize(node), Loader=yaml.CSafeLoader)
                if {"sites", "body", "gait"} & set(item):
                    items.append((node.start_mark.line + 1, item))
    return items


def spatial_motions() -> list[Path]:
    return [path for path in SHIPPED + TEST_MOTIONS if spatial_items(path)]


def test_shipped_motions_use_every_kind_of_spatial_keyframe():
    kinds = {key for path in spatial_motions() for _, item in spatial_items(path) for key in item}
    assert {"sites", "body", "gait"} <= kinds
    names = {path.stem for path in spatial_motions()}
    assert {"pick_and_place", "walk_forward", "turn_in_place", "side_step", "body_sway"} <= names


@pytest.mark.parametrize("path", spatial_motions(), ids=lambda p: p.name)
def test_every_ik_keyframe_of_the_shipped_motions_is_reached(path):
    """FK (MuJoCo) of each solved keyframe puts its sites where the file asks: within 1 mm and
    1°; body poses keep the feet where they stood; gaits put the feet where the gait says."""
    motion = load_motion(path)
    kin = kinematics(motion)
    by_line: dict[int, list] = {}
    for keyframe in motion.keyframes:
        by_line.setdefault(keyframe.where.line, []).append(keyframe)
    previous = np.array(motion.robot.pose_vector("home"), dtype=float)
    stance = previous
    checked = 0
    items = dict(spatial_items(path))
    for keyframe in motion.keyframes:
        line = keyframe.where.line
        item = items.get(line)
        angles = np.array(keyframe.targets_deg)
        assert np.all(angles >= kin.lower_deg) and np.all(angles <= kin.upper_deg)
        if item is None:
            stance = angles
        elif "sites" in item:
            for site, target in item["sites"].items():
                reached = kin.site_pose(site, angles)
                at = np.array(target["at"], dtype=float)
                if target.get("frame") == "world":
                    at = kin.world_to_base_mm(at)
                assert np.linalg.norm(reached.position_mm - at) <= POSITION_MM, (line, site)
                if "pitch" in target:
                    assert abs(reached.pitch_deg - target["pitch"]) <= ANGLE_DEG, (line, site)
                checked += 1
            stance = angles
        elif "body" in item:
            pose = {"x": "x_mm", "y": "y_mm", "z": "z_mm"}
            body = BodyPose(**{pose.get(k, f"{k}_deg"): v for k, v in item["body"].items()})
            planted = np.array([kin.site_pose(f, stance).position_mm for f in kin.feet()])
            expected = feet_under_body(planted, body)
            for foot, want in zip(kin.feet(), expected):
                assert np.linalg.norm(kin.site_pose(foot, angles).position_mm - want) <= 1.0
            checked += 1
        previous = angles
    gait_lines = [(line, item["gait"]) for line, item in spatial_items(path) if "gait" in item]
    for line, spec in gait_lines:
        frames = by_line[line]
        index = motion.keyframes.index(frames[0])
        before = np.array(motion.keyframes[index - 1].targets_deg)
        stance_mm = np.array([kin.site_pose(f, before).position_mm for f in kin.feet()])
        gait = Gait(
            Pattern(spec.get("pattern", "tripod")),
            spec["steps"],
            stride_mm=spec.get("stride", 40.0),
            sideways_mm=spec.get("sideways", 0.0),
            turn_deg=spec.get("turn", 0.0),
            lift_mm=spec.get("lift", 30.0),
        )
        # commanded as the robot file's gait: block makes up for its sag and slip
        expected = gait_keyframes(stance_mm, compensated(gait, motion.robot.gait))
        assert len(frames) == len(expected)
        for keyframe, want in zip(frames, expected):
            for foot, point in zip(kin.feet(), want.feet_mm):
                got = kin.site_pose(foot, keyframe.targets_deg).position_mm
                assert np.linalg.norm(got - point) <= POSITION_MM
            checked += 1
        # ends standing: the last keyframe is the stance it started from
        np.testing.assert_allclose(frames[-1].targets_deg, before, atol=0.05)
        assert frames[-1].stop
    assert checked


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text(text)
    return path


def load_error(path: Path) -> list[str]:
    with pytest.raises(SourceError) as caught:
        load_motion(path)
    return caught.value.problems


def test_unreachable_target_names_its_line_and_the_closest_point(tmp_path):
    path = write(
        tmp_path,
        "robot: arm6\nkeyframes:\n  - pose: home\n"
        "  - sites: {tool: {at: [600, 0, 100]}}\n    after: 1\n",
    )
    (message,) = load_error(path)
    assert message.startswith(f"{path}:4:13: site 'tool' cannot reach (600.0, 0.0, 100.0) mm ")
    assert "the closest it gets is (" in message
    # the arm reaches 335 mm from its shoulder axis (106 mm up): 265 mm short at best
    distance = float(message.split(" mm away")[0].rsplit(", ", 1)[1])
    assert 265 <= distance <= 266
    closest = message.split("the closest it gets is (")[1].split(")")[0]
    point = np.array([float(v) for v in closest.split(", ")])
    assert np.linalg.norm(point - [600, 0, 100]) == pytest.approx(distance, abs=0.1)


def test_validate_explains_an_ik_failure(tmp_path, capsys):
    path = write(
        tmp_path,
        "robot: arm6\nkeyframes:\n  - pose: {gripper: 30}\n"
        "  - sites: {tool: {at: [150, 0, 40], pitch: 60}}\n    pose: {wrist_roll: 0}\n"
        "    after: 1\n",
    )
    assert main(["validate", "--no-physics", str(path)]) == 1
    captured = capsys.readouterr()
    err = captured.out + captured.err
    assert (
        f"{path}:4:13: site 'tool' cannot reach (150.0, 0.0, 40.0) mm (base frame), pitch 60°"
        in err
    )
    assert "with wrist_roll held as given" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    "keyframes, expected",
    [
        (
            "  - sites: {toll: {at: [150, 0, 40]}}\n",
            "3:13: robot 'arm6' has no site 'toll' (did you mean 'tool'?); its sites: tool",
        ),
        (
            "  - body: {z: 10}\n",
            "3:5: body: needs the robot's feet: robot 'arm6' lists none",
        ),
        (
            "  - gait: {steps: 2}\n",
            "3:5: gait: needs the robot's feet: robot 'arm6' lists none",
        ),
        (
            "  - sites: {tool: {at: [150, 0]}}\n",
            "3:24: sites: tool: at must be [x, y, z] in mm, got 2 numbers",
        ),
        (
            "  - sites: {tool: {at: [150, 0, 40], frame: hand}}\n",
            "3:45: sites: tool: frame 'hand' is not one of base, world",
        ),
        (
            "  - sites: {tool: {at: [150, 0, 40]}}\n    body: {z: 1}\n",
            "4:5: give sites or body in a keyframe, not both",
        ),
        (
            "  - after: 1\n",
            "3:5: a keyframe needs pose, sites or body",
        ),
    ],
)
def test_bad_spatial_keyframes(tmp_path, keyframes, expected):
    path = write(tmp_path, "robot: arm6\nkeyframes:\n" + keyframes)
    messages = load_error(path)
    assert any(m.startswith(f"{path}:{expected}") for m in messages), messages


def test_bad_gait_blocks(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n"
        "  - gait: {pattern: tripd, steps: 0, period: 0}\n    after: 1\n",
    )
    messages = load_error(path)
    assert f"{path}:4:21: gait: pattern 'tripd' is not one of tripod, ripple, wave" in messages[0]
    assert any(":4:35: gait: steps must be" in m for m in messages)
    assert any(":4:46: gait: period must be" in m for m in messages)
    assert any(":5:5: unknown key 'after' in a gait block" in m for m in messages)


def test_a_gait_too_long_for_the_legs_is_reported_with_the_step(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n  - gait: {steps: 3, stride: 400}\n",
    )
    (message,) = load_error(path)
    assert message.startswith(f"{path}:4:5: gait step 1 of 3: foot ")
    assert "the closest it gets is" in message


def test_a_mirrored_include_of_spatial_keyframes_is_refused(tmp_path):
    (tmp_path / "part.yaml").write_text(
        "robot: arm6\nkeyframes:\n  - sites: {tool: {at: [150, 0, 40]}}\n"
    )
    path = write(tmp_path, "robot: arm6\nkeyframes:\n  - include: part.yaml\n    mirror: true\n")
    messages = load_error(path)
    assert any("cannot be mirrored" in m for m in messages)


def test_joints_given_alongside_sites_stay_fixed(tmp_path):
    path = write(
        tmp_path,
        "robot: arm6\nkeyframes:\n  - pose: home\n"
        "  - sites: {tool: {at: [160, 60, 60], pitch: -60}}\n"
        "    pose: {wrist_roll: 25, gripper: 35}\n    after: 1.5\n",
    )
    motion = load_motion(path)
    targets = dict(zip(motion.robot.joint_names, motion.keyframes[1].targets_deg))
    assert targets["wrist_roll"] == 25 and targets["gripper"] == 35
    reached = Kinematics(motion.robot).site_pose("tool", motion.keyframes[1].targets_deg)
    assert np.linalg.norm(reached.position_mm - [160, 60, 60]) <= POSITION_MM


def test_world_frame_targets_of_a_walker(tmp_path):
    """The hexapod's torso stands 85.9 mm up at home: a foot at world z 10 is at base z -75.9."""
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n"
        "  - sites: {lf_foot: {at: [200, 160, 30], frame: world}}\n    after: 1\n",
    )
    motion = load_motion(path)
    reached = Kinematics(motion.robot).site_pose("lf_foot", motion.keyframes[1].targets_deg)
    np.testing.assert_allclose(reached.position_mm, [200, 160, 30 - 85.9], atol=POSITION_MM)


def test_plan_json_lists_the_expanded_keyframes(capsys):
    path = REPO / "motions" / "hexapod18" / "walk_forward.yaml"
    assert main(["plan", "--json", str(path)]) == 0
    report = json.loads(capsys.readouterr().out)
    listed = report["expanded_keyframes"]
    motion = load_motion(path)
    assert len(listed) == len(motion.keyframes) == 1 + 6 * 2 * 4  # home + steps x groups x 4
    assert listed[1]["where"] == f"{path}:9:5" or listed[1]["where"].endswith(":9:5")
    assert listed[1]["after_s"] == pytest.approx(2.0 / 8)
    assert set(listed[1]["targets_deg"]) == set(motion.robot.joint_names)
    assert listed[-1]["stop"] is True


def test_a_gait_walks_in_the_body_pose_it_starts_from(tmp_path):
    """Body 20 mm up, then a walk: the walk ends in that raised pose, and a body pose after it
    is relative to where the walk left the body."""
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n  - body: {z: 20}\n    after: 1\n"
        "  - gait: {steps: 2, stride: 30}\n  - body: {z: 0}\n    after: 1\n",
    )
    motion = load_motion(path)
    raised, *walk, after = motion.keyframes[1:]
    np.testing.assert_allclose(walk[-1].targets_deg, raised.targets_deg, atol=0.05)
    np.testing.assert_allclose(after.targets_deg, raised.targets_deg, atol=0.05)
    kin = Kinematics(motion.robot)
    home = motion.robot.pose_vector("home")
    for foot in kin.feet():
        dz = kin.site_pose(foot, raised.targets_deg).position_mm[2]
        assert dz == pytest.approx(kin.site_pose(foot, home).position_mm[2] - 20, abs=POSITION_MM)


def test_a_body_pose_too_far_names_the_foot(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n  - body: {z: 150}\n    after: 1\n",
    )
    (message,) = load_error(path)
    assert message.startswith(f"{path}:4:5: body: foot '")
    assert "mm (body frame): the closest it gets is (" in message
    assert message.endswith("ask for a smaller move")


@pytest.mark.parametrize(
    "keyframe, expected",
    [
        (
            "sites: {tool: {at: [1.0e+300, 0, 40]}}",
            "4:25: sites: tool: at must be in -10000..10000, got 1e+300",
        ),
        ("body: {z: -1.0e+300}", "4:15: body: z must be in -10000..10000, got -1e+300"),
        ("body: {roll: 720}", "4:18: body: roll must be in -180..180, got 720"),
        (
            "gait: {steps: 2, stride: 1.0e+300}",
            "4:30: gait: stride must be in -10000..10000, got 1e+300",
        ),
    ],
)
def test_huge_coordinates_are_refused_at_their_number_without_overflow(
    tmp_path, keyframe, expected
):
    path = write(tmp_path, f"robot: hexapod18\nkeyframes:\n  - pose: home\n  - {keyframe}\n")
    if keyframe.startswith("sites"):
        path.write_text(path.read_text().replace("hexapod18", "arm6"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow RuntimeWarning fails the test
        assert load_error(path) == [f"{path}:{expected}"]


def test_a_gait_of_more_keyframes_than_a_motion_plays_is_refused_from_its_step_count(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n  - gait: {pattern: wave, steps: 100000}\n",
    )
    assert load_error(path) == [
        f"{path}:4:34: gait: steps 100000 of the wave gait are 2400000 keyframes (24 a step), "
        "with the motion's 1 other keyframe; at most 10000 are played in one motion: steps at "
        "most 416"
    ]


@pytest.mark.parametrize(
    "pattern, most, keyframes", [("tripod", 1249, 9992), ("ripple", 833, 9998), ("wave", 416, 9984)]
)
def test_a_gait_after_a_pose_is_played_up_to_the_documented_steps(
    tmp_path, pattern, most, keyframes
):
    """With the pose before it the motion plays at most 10,000 keyframes: the steps the docs
    give pass the count (arm6 has no feet, which is said only after counting: solving 10,000
    keyframes by IK takes 20 s), one more is refused at its steps."""
    head = "robot: arm6\nkeyframes:\n  - pose: home\n"
    path = write(tmp_path, f"{head}  - gait: {{pattern: {pattern}, steps: {most}}}\n")
    assert load_error(path) == [
        f"{path}:4:5: gait: needs the robot's feet: robot 'arm6' lists none (add <custom><text "
        'name="choreo:feet" data="foot_site ..."/></custom> to its MJCF)'
    ]
    assert Gait(Pattern(pattern), most).keyframes == keyframes
    path.write_text(f"{head}  - gait: {{pattern: {pattern}, steps: {most + 1}}}\n")
    [message] = load_error(path)
    assert message.endswith(
        "with the motion's 1 other keyframe; at most 10000 are played in one motion: "
        f"steps at most {most}"
    )


def test_the_documented_most_gait_steps_are_the_codes():
    row = next(
        line
        for line in (REPO / "docs" / "motion-format.md").read_text().splitlines()
        if line.startswith("| `steps` |")
    )
    gaits = [Gait(pattern, 1) for pattern in (Pattern.TRIPOD, Pattern.RIPPLE, Pattern.WAVE)]
    tripod, ripple, wave = (gait.keyframes_per_step for gait in gaits)
    assert gaits[1].keyframes == ripple + 2
    assert f"a step is {tripod} (tripod), {ripple} (ripple, 2 more at the end) or {wave}" in row
    tripod, ripple, wave = (most_gait_steps(gait, other_keyframes=1) for gait in gaits)
    assert f"at most {tripod} tripod, {ripple} ripple or {wave} wave steps" in row


def test_the_longest_of_several_gaits_is_named_with_the_others_counted(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nkeyframes:\n  - pose: home\n  - gait: {steps: 1000}\n"
        "  - gait: {steps: 300}\n",
    )
    assert load_error(path) == [
        f"{path}:4:19: gait: steps 1000 of the tripod gait are 8000 keyframes (8 a step), with "
        "the motion's 2401 other keyframes; at most 10000 are played in one motion: steps at "
        "most 949"
    ]


def test_gaits_and_repeat_together_are_counted_before_the_gaits_are_solved(tmp_path):
    path = write(
        tmp_path,
        "robot: hexapod18\nrepeat: 10\nkeyframes:\n  - pose: home\n  - gait: {steps: 1000}\n",
    )
    assert load_error(path) == [
        f"{path}:2:9: repeat 10 x 8001 keyframe(s) = 80010 keyframes to play; at most 10000 are "
        "played in one motion: at most 1 time"
    ]


def test_a_gait_commands_what_the_robot_falls_short_of_and_a_lift_of_0_stays_0():
    by = GaitCompensation(lift_sag_mm=7, stride_scale=1.06, turn_scale=1.16)
    asked = Gait(Pattern.RIPPLE, 4, stride_mm=40, sideways_mm=-30, turn_deg=10, lift_mm=25)
    commanded = compensated(asked, by)
    assert (commanded.stride_mm, commanded.sideways_mm) == pytest.approx((42.4, -31.8))
    assert (commanded.turn_deg, commanded.lift_mm) == pytest.approx((11.6, 32))
    assert (commanded.pattern, commanded.steps, commanded.period_s) == (Pattern.RIPPLE, 4, 2.0)
    assert compensated(Gait(Pattern.TRIPOD, 1, lift_mm=0), by).lift_mm == 0  # meant to slide


def test_the_documented_tripod_steps_plus_one_after_home_is_one_line(tmp_path, capsys):
    path = write(
        tmp_path, "robot: hexapod18\nkeyframes:\n  - pose: home\n  - gait: {steps: 1250}\n"
    )
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:4:19: gait: steps 1250 of the tripod gait are 10000 keyframes "
        "(8 a step), with the motion's 1 other keyframe; at most 10000 are played in one motion: "
        "steps at most 1249"
    )
