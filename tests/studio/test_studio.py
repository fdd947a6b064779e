"""choreo studio without a browser: the keyframe edits (golden texts written by hand), the
session that keeps the last good plan, the file watcher and the command line."""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from emulated import home_specs, wait_for
from paths import DATA
from studio_helpers import body_sway_rise, copy_motion, studio_on

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.core.atomic import write_text_atomically
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, SimSerial
from choreo.errors import SourceError
from choreo.motion.music_block import BeatGrid
from choreo.plan.planner import APPROACH_LIMIT_SCALE
from choreo.preview.step_loop import JOIN_TOLERANCE
from choreo.robot.kinematics import Kinematics
from choreo.robot.robot_file import load_robot
from choreo.studio.address import Address
from choreo.studio.live import LiveRobot
from choreo.studio.scene import rotation_of
from choreo.studio.server import LatestOnly, Studio, check_loads
from choreo.studio.session import Session, simulate_plan
from choreo.studio.watch import FileWatcher
from choreo.studio.yaml_edit import (
    EditRefused,
    add_keyframe,
    delete_keyframe,
    keyframe_items,
    pose_mapping,
    retime_keyframe,
    sites_mapping,
    update_keyframe,
    update_site,
    written_time,
)

MOTION = DATA / "studio" / "wave.yaml"
TEXT = MOTION.read_text()
ROUNDING = 1.05  # a move's units and milliseconds are whole numbers: its speed is a bit off

# A file written by hand the way people do: a wrapped flow mapping, anchors, a bar and beat,
# comments everywhere. The edits below must leave every line they don't own as it is.
HAND_WRITTEN = """\
robot: arm6   # the desk arm
keyframes:
  - pose: home
  # a wrapped flow mapping
  - pose: {base_yaw: 10, shoulder: 20,
           elbow: 30}
    after: 1.0  # slow
  - pose: &up {shoulder: -20}
    after: 0.5
  - pose: *up
    after: 0.5
    hold: 0.2   # wait
speed: 1.0
"""


def test_keyframe_items_span_their_own_lines_and_leave_comments_to_the_next():
    items = keyframe_items(HAND_WRITTEN)
    assert [(i.first_line, i.last_line) for i in items] == [(2, 2), (4, 6), (7, 8), (9, 11)]
    assert {i.dash_col for i in items} == {2}


def test_update_rewrites_the_pose_and_keeps_the_timing_and_its_comment():
    pose = pose_mapping({"base_yaw": 12.34, "shoulder": -0.04})
    new = update_keyframe(HAND_WRITTEN, 1, "here", "pose", pose)
    assert new == HAND_WRITTEN.replace(
        "  - pose: {base_yaw: 10, shoulder: 20,\n           elbow: 30}\n",
        "  - pose: {base_yaw: 12.3, shoulder: 0}\n",
    )


def test_retime_replaces_after_beat_or_bar_by_t_keeping_the_line_comment():
    new = retime_keyframe(HAND_WRITTEN, 1, "here", {"t": 1.25})
    assert new == HAND_WRITTEN.replace("    after: 1.0  # slow\n", "    t: 1.25  # slow\n")
    music = "robot: arm6\nkeyframes:\n  - pose: home\n    bar: 2\n    beat: 3\n    stop: true\n"
    assert retime_keyframe(music, 0, "here", {"t": 2}) == (
        "robot: arm6\nkeyframes:\n  - pose: home\n    t: 2\n    stop: true\n"
    )


def test_a_dance_is_edited_in_beats_and_times_outside_the_song_in_seconds():
    grid = BeatGrid((0.0, 0.5, 1.0, 1.5), beats_per_bar=4)  # 120 BPM, beat 1 at t 0
    assert written_time("beat", 0.75, None, grid) == {"beat": 2.5}
    assert written_time("beat", 1.0, None, grid) == {"beat": 3}  # on a beat: a whole number
    assert written_time("bar", 1.0, None, grid) == {"bar": 1, "beat": 3}
    assert written_time("bar", 0.0, None, grid) == {"bar": 1}  # a bar's first beat
    assert written_time("beat", 2.0, None, grid) == {"t": 2}  # past the song's last beat
    assert written_time("beat", 0.75, None, None) == {"t": 0.75}  # no music block
    assert written_time("after", 0.75, 0.5, None) == {"after": 0.25}
    music = "robot: arm6\nkeyframes:\n  - pose: home\n    bar: 2\n    beat: 3\n    stop: true\n"
    assert retime_keyframe(music, 0, "here", written_time("beat", 1.0, None, grid)) == (
        "robot: arm6\nkeyframes:\n  - pose: home\n    beat: 3\n    stop: true\n"
    )


def test_add_inserts_a_full_pose_after_the_keyframe_before_it():
    pose = pose_mapping({"base_yaw": 5, "shoulder": 7.5})
    new = add_keyframe(HAND_WRITTEN, 0, "pose", pose, {"t": 0.5})
    assert new == HAND_WRITTEN.replace(
        "  - pose: home\n", "  - pose: home\n  - pose: {base_yaw: 5, shoulder: 7.5}\n    t: 0.5\n"
    )
    first = add_keyframe(HAND_WRITTEN, None, "pose", pose_mapping({"gripper": 10}), {"t": 0})
    assert first.startswith("robot: arm6   # the desk arm\nkeyframes:\n  - pose: {gripper: 10}\n")


def test_a_site_handle_moves_the_site_it_had_keeping_its_pitch_and_its_pose():
    text = (
        "robot: arm6\nkeyframes:\n  - pose: home\n"
        "  - sites: {tool: {at: [100, 0, 50], pitch: -70}}  # reach\n"
        "    pose: {gripper: 40}\n    after: 1.5\n"
    )
    new = update_site(text, 1, "here", "tool", [120.04, -3.25, 60])
    assert new == text.replace("[100, 0, 50]", "[120, -3.2, 60]")
    # a site written over a joint pose: the pose stays beside it
    replaced = update_keyframe(text, 1, "here", "sites", sites_mapping("tool", [1, 2, 3], -60))
    assert replaced == text.replace(
        "{tool: {at: [100, 0, 50], pitch: -70}}", "{tool: {at: [1, 2, 3], pitch: -60}}"
    )


def test_delete_removes_only_the_keyframe_lines():
    assert delete_keyframe(HAND_WRITTEN, 1) == HAND_WRITTEN.replace(
        "  - pose: {base_yaw: 10, shoulder: 20,\n           elbow: 30}\n    after: 1.0  # slow\n",
        "",
    )
    with pytest.raises(EditRefused, match="last one"):
        delete_keyframe("robot: arm6\nkeyframes:\n  - pose: home\n", 0)


@pytest.mark.parametrize("index", [2, 3])
def test_keyframes_tied_by_an_anchor_or_alias_are_left_to_the_text_editor(index):
    with pytest.raises(EditRefused, match=r"^motion.yaml:9: .*YAML (anchor|alias)"):
        update_keyframe(HAND_WRITTEN, index, "motion.yaml:9", "pose", pose_mapping({"shoulder": 1}))


def test_a_bad_edit_is_refused_before_anything_is_written(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    # the second keyframe moved after the third: the third's t now goes backwards
    with pytest.raises(SourceError, match=rf"^{re.escape(str(path))}:11:8: t 2 goes backwards"):
        check_loads(path, retime_keyframe(TEXT, 1, "here", {"t": 2.5}))
    assert path.read_text() == TEXT
    assert sorted(p.name for p in tmp_path.iterdir()) == ["groove.ogg", "wave.yaml"]


def test_the_session_keeps_the_last_good_plan_and_says_where_the_file_is_wrong(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    session = Session(path)
    assert session.reload().problems == ()
    good = session.plan
    assert good is not None and good.keyframe_times_s[1:] == (1.0, 2.0, 3.0)
    assert path.resolve() in session.watched_files
    assert (DATA.parent.parent / "models" / "arm6" / "robot.yaml").resolve() in (
        session.watched_files
    )

    path.write_text(TEXT.replace("elbow: 40", "elbow: 400"))
    problems = session.reload().problems
    assert problems and problems[0].startswith(f"{path}:8:")
    assert "elbow" in problems[0] and session.plan is good

    assert not session.changed_on_disk()
    path.write_text(TEXT)
    assert session.changed_on_disk()
    assert session.reload().problems == () and session.plan is not good


def test_the_plan_comes_first_and_the_physics_of_a_superseded_reload_is_dropped(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    session = Session(path)
    first = session.reload()
    plan = session.plan
    assert plan is not None and plan.physics is None  # planned, not simulated yet
    # the third keyframe, as the file writes it: base_yaw 30 with shoulder 30, elbow 40 kept
    assert np.allclose(plan.planned_deg(2.0)[:3], [30, 30, 40], atol=0.5)
    assert plan.start_s == 0.0 and plan.phase(-0.5) == "approach"  # from home: no approach

    second = session.reload()  # a save while the first reload was to be simulated
    assert session.simulate(first.version) is None and session.plan.physics is None
    assert session.simulate(second.version) == second
    physics = session.plan.physics
    assert physics is not None and session.plan.motion is not plan.motion
    # the plan shown first is the path the simulated servos were given
    times = np.linspace(plan.start_s, plan.end_s, 50)
    given = physics.rollout.command_deg[physics.steps_at(times)]
    assert np.allclose(given, [session.plan.planned_deg(t) for t in times], atol=0.5)
    assert np.allclose(physics.simulated_deg(np.array([2.0]))[0][:3], [30, 30, 40], atol=2.0)
    assert session.simulate(second.version) is None  # simulated already


def swaying_arm(first_yaw_deg: float) -> str:
    """arm6 swaying through a keyframe a second for 8 s, then reaching down onto the floor."""
    lines = ["robot: arm6", "keyframes:", "  - pose: home"]
    for t in range(1, 9):
        yaw = first_yaw_deg if t == 1 else (-1) ** t * 20
        lines += [f"  - pose: {{base_yaw: {yaw}, shoulder: 10, elbow: 20}}", f"    t: {t}"]
    lines += ["  - pose: {shoulder: 90, elbow: 90}", "    t: 10"]
    return "\n".join(lines) + "\n"


def test_a_save_that_changes_the_first_keyframe_simulates_until_the_arm_is_back_on_its_old_path(
    tmp_path,
):
    path = tmp_path / "sway.yaml"
    path.write_text(swaying_arm(20))
    session = Session(path)
    session.simulate(session.reload().version)
    before = session.plan.physics.rollout
    path.write_text(swaying_arm(25))
    session.simulate(session.reload().version)
    physics = session.plan.physics
    fresh = simulate_plan(session.plan)  # without the last run
    # the last run's later checkpoints were taken, not simulated again
    theirs = {id(c.state) for c in before.resume.checkpoints}
    assert any(id(c.state) in theirs for c in physics.rollout.resume.checkpoints)
    apart_deg = np.abs(physics.rollout.position_deg - fresh.rollout.position_deg).max()
    assert apart_deg <= np.degrees(JOIN_TOLERANCE)
    # the findings are the whole run's, of its spliced rest too: the reach onto the floor
    assert physics.rollout.times_s[-1] == fresh.rollout.times_s[-1] > 10
    assert [(f.kind, f.time_s, f.joint) for f in physics.findings] == [
        (f.kind, f.time_s, f.joint) for f in fresh.findings
    ]
    assert "floor_contact" in {f.kind.value for f in physics.findings if f.time_s > 9}


@dataclass(frozen=True)
class Watching:
    """A FileWatcher, and how many times it has read its files (once at each poll)."""

    watcher: FileWatcher
    reads: list[int]

    def polls_done(self, count: int = 2) -> None:
        """Until ``count`` more polls have run to their end (the one after them has begun):
        whatever they would call, they have called. Not a fixed sleep: on a busy machine one
        saw fewer polls than it allowed for."""
        since = self.reads[0]
        wait_for(lambda: self.reads[0] > since + count, f"{count} polls of the watcher")


@contextmanager
def watching(files: Callable[[], list[Path]], on_change: Callable[[], None]) -> Iterator[Watching]:
    """A FileWatcher polling ``files``, stopped when the block ends."""
    reads = [0]

    def read() -> list[Path]:
        reads[0] += 1
        return files()

    watched = Watching(FileWatcher(read, on_change), reads)
    watched.watcher.start()
    try:
        yield watched
    finally:
        watched.watcher.stop()


def test_the_watcher_notices_a_save(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text(TEXT)
    changed = threading.Event()
    with watching(lambda: [path], changed.set) as watched:
        watched.polls_done()
        assert not changed.is_set()
        path.write_text(TEXT + "# saved again\n")
        assert changed.wait(5.0)


def test_what_the_studio_writes_itself_is_no_save(tmp_path):
    """A poll between the studio's write and its noting it would reload (and simulate) the
    studio's own edit a second time, after the studio's reload."""
    path = tmp_path / "wave.yaml"
    path.write_text(TEXT)
    changed = threading.Event()
    with watching(lambda: [path], changed.set) as watched:
        with watched.watcher.writing():
            write_text_atomically(path, TEXT + "# written by the studio\n")
            time.sleep(0.3)  # the polls due meanwhile wait for the write to be noted
        watched.polls_done()
        assert not changed.is_set()
        path.write_text(TEXT + "# saved in an editor\n")
        assert changed.wait(5.0)


def test_a_file_the_reload_brought_in_or_dropped_is_no_save(tmp_path):
    """A save that adds a song (or drops one) changes the set of files watched: that is one
    reload, not two (the second would refuse the page's next edit as made on an older one)."""
    path, song = tmp_path / "wave.yaml", tmp_path / "groove.ogg"
    path.write_text(TEXT)
    song.write_bytes(b"song")
    files = [path]
    reloads = []

    def reload() -> None:  # as the studio's: the files are asked for again after it
        files[:] = [path, song] if len(files) == 1 else [path]
        reloads.append(len(files))

    with watching(lambda: list(files), reload) as watched:
        write_text_atomically(path, TEXT + "# with its song\n")  # one save, seen once
        wait_for(lambda: reloads == [2], "the reload that brings the song in")
        watched.polls_done()  # polls that see the song: no save
        assert reloads == [2]
        write_text_atomically(path, TEXT + "# without it\n")
        wait_for(lambda: reloads == [2, 1], "the reload that drops it")
        watched.polls_done()
        song.write_bytes(b"no longer watched")
        write_text_atomically(path, TEXT)
        wait_for(lambda: len(reloads) == 3, "a save of the motion")
        watched.polls_done()
        assert reloads == [2, 1, 2]


def test_the_live_robot_follows_the_page_within_the_approach_limits_and_stops(tmp_path):
    robot = load_robot("arm6")
    clock = VirtualClock()
    emulator = BusEmulator(home_specs(robot), clock=clock)
    bus = ServoBus(SimSerial.from_emulator(emulator))
    said: list[str] = []
    live = LiveRobot(bus, robot, clock, say=said.append)  # preflight: reads, loads torque
    try:
        target = np.array(robot.pose_vector("ready"))
        live.follow(target)
        wait_for(lambda: np.allclose(live.pose_deg, target), "the robot to reach 'ready'")
        moves = [m for m in emulator.log.moves if m.command is not Command.MOVE_STOP]
        assert moves, "nothing moved"
        for move in moves:  # never a jump: every move at most the approach's share of vmax
            joint = next(j for j in robot.joints if j.servo_id == move.servo_id)
            speed = abs(joint.to_deg(move.to_units) - joint.to_deg(move.from_units))
            if move.duration_s > 0:
                speed /= move.duration_s
            assert speed <= joint.limits.vel_deg_s * APPROACH_LIMIT_SCALE * ROUNDING
        reached = [bus.read_position(j.servo_id) for j in robot.joints]
        assert np.allclose(robot.to_deg(reached), target, atol=0.5)

        live.stop()
        wait_for(lambda: "stopped the servos" in said, "the stop")
        stops = [p for p in emulator.log.packets if p.packet.command == Command.MOVE_STOP]
        assert stops, "no MOVE_STOP sent"

        # posed by hand: unloaded, turned, read, loaded again
        live.unload(["shoulder"])
        assert [emulator.servo(i).loaded for i in (1, 2)] == [True, False]
        emulator.servo(2).move_by_hand(600)  # (600 - 500) * 0.24 = 24°
        assert live.read_pose()[1] == pytest.approx(24.0)
        live.follow(target)  # a robot in someone's hands is not driven
        live.hold()
        assert emulator.servo(2).loaded and live.limp == ()
        assert bus.read_position(2) == 600
    finally:
        live.close()


def test_a_site_handle_poses_the_arm_by_ik_and_add_keyframe_writes_sites(tmp_path):
    path = tmp_path / "wave.yaml"
    copy_motion(path)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append)
    studio.start()
    try:
        kinematics = Kinematics(load_robot("arm6"))
        target_mm = np.array([102.8, 122.6, 90.0])  # pick_and_place.yaml's block, reachable
        origin = kinematics.world_to_base_mm([0, 0, 0])
        axes = np.stack([kinematics.world_to_base_mm(e) - origin for e in np.eye(3) * 1000], 1)
        world_m = np.linalg.solve(axes, target_mm - origin)
        assert "reload 1 simulated in " in studio.page.status.content
        studio.select_keyframe(2)  # the third: where it is written, when, and its values
        assert studio.page.keyframe_info.content == (
            f"`{path}:10:5` at 2.00 s: base_yaw 30°, shoulder 30°, elbow 40°, wrist_pitch 0°, "
            "wrist_roll 0°, gripper 0°"
        )
        assert studio.time_s == 2.0
        studio.scrub(3.4)  # past the last keyframe (t 3): the new one goes at the end
        studio.drag_site("tool", world_m)
        assert studio.posing is not None
        reached = kinematics.site_pose("tool", studio.posing).position_mm
        assert np.allclose(reached, target_mm, atol=1.0)
        studio.add_keyframe()  # too soon after the last keyframe for the limits: refused
        assert said[-1].startswith("⛔ nothing written: at 3.40 s it would not plan: ")
        assert said[-1].endswith("; the nearest time that works is 3.50 s")
        assert path.read_text() == TEXT
        studio.scrub(3.5)
        studio.drag_site("tool", world_m)
        studio.add_keyframe()
        assert not [line for line in said[-3:] if "nothing written" in line]
        assert (
            # timed as the keyframe before it is, with t
            path.read_text() == TEXT + "  - sites: {tool: {at: [102.8, 122.6, 90]}}\n    t: 3.5\n"
        )
        studio.drive(True)  # a request its page does not offer: it was given no robot
        studio.read_pose()
        refused = "⛔ refused: no robot: this studio was started without one to drive"
        assert said[-2:] == [refused, refused]
        assert not studio.driving
    finally:
        studio.close()


# hexapod18 stands at home, rises 20 mm on its planted feet (a body: keyframe), crouches.
BODY_MOTION = """\
robot: hexapod18
keyframes:
  - pose: home
  - body: {z: 20}   # up
    t: 1.0
  - pose: crouch
    t: 2.0
"""


def turned(wxyz: np.ndarray, roll_deg: float) -> np.ndarray:
    """The quaternion ``wxyz`` followed by a roll about its own x axis."""
    half = np.radians(roll_deg) / 2
    w, x, y, z = wxyz
    c, s = np.cos(half), np.sin(half)
    return np.array([w * c - x * s, x * c + w * s, y * c + z * s, z * c - y * s])


def test_the_body_handle_poses_a_walker_on_its_planted_feet_and_writes_body(tmp_path):
    path = tmp_path / "rise.yaml"
    path.write_text(BODY_MOTION)
    said: list[str] = []
    studio = Studio(path, Address("127.0.0.1", 0), say=said.append)
    studio.start()
    try:
        assert studio.view is not None
        kinematics = Kinematics(load_robot("hexapod18"))
        feet = kinematics.feet()
        studio.scrub(2.5)  # after the last keyframe: the feet stand where crouch plants them
        crouch = studio.session.plan.motion.keyframes[2].targets_deg
        position, wxyz = studio.view.root_pose()
        up = position + rotation_of(wxyz) @ np.array([0.0, 0.0, 0.020])
        studio.drag_body(up, turned(wxyz, 5.0))  # 20 mm up, rolled 5°
        assert studio.posing is not None
        # every foot stays where it stood: stance = R posed + t (body frame, mm), R a 5° roll
        roll = np.radians(5.0)
        rotation = np.array(
            [[1, 0, 0], [0, np.cos(roll), -np.sin(roll)], [0, np.sin(roll), np.cos(roll)]]
        )
        for foot in feet:
            stood = kinematics.site_pose(foot, crouch).position_mm
            posed = kinematics.site_pose(foot, studio.posing).position_mm
            assert np.allclose(rotation @ posed + [0, 0, 20], stood, atol=1.0)

        posed = studio.posing.copy()
        studio.drag_body(position + np.array([0.0, 0.0, 0.3]), wxyz)  # 30 cm up: out of reach
        assert re.fullmatch(
            r"⛔ refused: the body cannot go there: foot \w+ would end \d+ mm from where it "
            r"stands \(out of the leg's reach\); the last pose that works stays",
            said[-1],
        )
        assert np.array_equal(studio.posing, posed)

        studio.add_keyframe()
        assert path.read_text() == BODY_MOTION + "  - body: {z: 20, roll: 5}\n    t: 2.5\n"

        studio.select_keyframe(1)  # the body: keyframe at t 1: 10 mm more, from home's feet
        position, wxyz = studio.view.root_pose()
        studio.drag_body(position + rotation_of(wxyz) @ np.array([0.0, 0.0, 0.010]), wxyz)
        studio.update_keyframe()
        assert not [line for line in said if "nothing written" in line]
        written = path.read_text()
        assert written.startswith(
            BODY_MOTION.replace("body: {z: 20}   # up", "body: {z: 30}   # up")
        )

        # crouch made a body: keyframe would rise from home's feet (the keyframe before it
        # that planted them), not from crouch's, where the handle kept them: refused
        studio.select_keyframe(2)
        position, wxyz = studio.view.root_pose()
        studio.drag_body(position + rotation_of(wxyz) @ np.array([0.0, 0.0, 0.010]), wxyz)
        studio.update_keyframe()
        assert said[-1].startswith("⛔ nothing written: a body: keyframe there would stand on ")
        assert path.read_text() == written
    finally:
        studio.close()


def test_drag_moves_that_come_while_one_is_solved_are_dropped_but_the_newest():
    handled: list[int] = []
    solving, release = threading.Event(), threading.Event()

    def solve(move: int) -> None:
        handled.append(move)
        if move == 1:  # a slow solve: moves 2, 3 and 4 arrive meanwhile
            solving.set()
            assert release.wait(5.0)

    latest = LatestOnly(solve)
    first = threading.Thread(target=latest, args=(1,))
    first.start()
    assert solving.wait(5.0)
    for move in (2, 3, 4):
        latest(move)  # returns at once: the call under way takes the newest next
    assert handled == [1]
    release.set()
    first.join(5.0)
    assert handled == [1, 4]
    latest(5)
    assert handled == [1, 4, 5]


def test_a_save_for_another_robot_drops_the_pose_of_the_one_shown(tmp_path):
    """The sliders' pose was the robot's shown before: its joints are not the new robot's (the
    reload failed on it, the page left half shown)."""
    with studio_on(tmp_path, "arm6/wave.yaml") as studio:
        studio.move_joint("elbow", -20)
        assert studio.posing is not None
        write_text_atomically(studio.session.motion_path, body_sway_rise())
        studio.reload()
        assert studio.session.problems == () and studio.posing is None
        assert studio.view is not None and studio.view.robot.name == "hexapod18"
