"""Teach by hand (choreo.play.recorder, `choreo record`): servos turned by hand on the emulator in
virtual time; the journal survives a SIGKILL (the one test on the real clock, over a pty)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest
import yaml
from cli_helpers import main_while, packets, signal_noted
from emulated import PATIENT_READS, WAIT_S, home_specs, wait_for

from choreo.bus.protocol import Command
from choreo.bus.servo_bus import ServoBus
from choreo.cli import main
from choreo.cli.record_commands import KEYS
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection
from choreo.errors import BusError, ChoreoError, OptionError
from choreo.motion.motion_file import load_motion
from choreo.play.recorder import (
    INPUT_POLL_S,
    Captured,
    Ending,
    NothingToUndo,
    Recorder,
    Refused,
    Undone,
    UnknownInput,
)
from choreo.play.recording import (
    Recording,
    SavedMotion,
    journal_path,
    read_journal,
)
from choreo.robot.robot_file import load_robot

TINY = "tests/data/models/tiny/robot.yaml"


class Rig:
    """A robot's servos on an emulated bus in virtual time, standing at home."""

    def __init__(self, robot: str = "arm6", skip_ids=()):
        self.robot = load_robot(robot)
        self.clock = VirtualClock()
        specs = [s for s in home_specs(self.robot) if s.servo_id not in skip_ids]
        self.emulator = BusEmulator(specs, clock=self.clock)
        self.bus = ServoBus(connection(self.emulator))
        self.events = []

    def servo(self, servo_id: int):
        return self.emulator.servo(servo_id)

    def recorder(self, recording: Recording, **options) -> Recorder:
        return Recorder(self.bus, recording, self.clock, on_event=self.events.append, **options)

    def record(self, out, lines, *, resume=False, **options):
        recording = Recording.resume(out) if resume else Recording.start(out, self.robot)
        with self.recorder(recording, **options) as recorder:
            ending = recorder.run_keyframes(lines)
        return recording, ending


def journal_records(out):
    return [json.loads(line) for line in journal_path(out).read_text().splitlines()]


# --- keyframes ---------------------------------------------------------------------------------


def test_poses_turned_by_hand_are_saved_as_keyframes_that_validate(tmp_path, capsys):
    rig = Rig()
    out = tmp_path / "taught.yaml"

    def typing():
        assert [rig.servo(i).loaded for i in range(1, 7)] == [True, False, False, True, True, False]
        rig.servo(2).move_by_hand(600)  # shoulder: (600 - 500) * 0.24 = 24°
        yield ""
        rig.clock.advance(1.5)
        rig.servo(3).move_by_hand(400)  # elbow: -24°
        rig.servo(6).move_by_hand(575)  # gripper, zero 700, direction -1: 30°
        yield ""
        yield "q"

    recording, ending = rig.record(out, typing(), taught=["shoulder", "elbow", "gripper"])
    assert ending is Ending.QUIT
    assert recording.save() == SavedMotion(out, 2, 2)
    assert main(["validate", str(out)]) == 0
    motion = load_motion(out)
    assert [k.targets_deg for k in motion.keyframes] == [
        (0, 24, 0, 0, 0, 0),
        (0, 24, -24, 0, 0, 30),
    ]
    assert motion.keyframes[0].after_s is None
    assert motion.keyframes[1].after_s == pytest.approx(1.5, abs=0.02)  # plus the reads' bus time
    assert "robot: arm6\n" in out.read_text()
    assert not journal_path(out).exists()
    # the taught joints hold where they were left
    assert all(servo.loaded for servo in rig.emulator.servos)
    assert [round(rig.servo(i).position_units) for i in (2, 3, 6)] == [600, 400, 575]
    assert [type(e) for e in rig.events] == [Captured, Captured]


def test_every_capture_is_on_disk_before_the_next_line_is_read(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    seen = []

    def typing():
        rig.servo(1).move_by_hand(250)  # base_yaw -60°
        yield ""
        seen.append(journal_records(out))
        yield "q"

    rig.record(out, typing())
    header, capture = seen[0]
    assert header["format"] == "choreo-record-journal" and header["joints"][0] == "base_yaw"
    assert capture == {
        "capture": 1,
        "after_s": None,
        "stream": None,
        "angles_deg": {
            "base_yaw": -60.0,
            "shoulder": 0.0,
            "elbow": 0.0,
            "wrist_pitch": 0.0,
            "wrist_roll": 0.0,
            "gripper": 0.0,
        },
    }


def test_a_pose_outside_the_limits_is_refused_naming_joint_value_and_range(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"

    def typing():
        rig.servo(3).move_by_hand(990)  # elbow: 490 * 0.24 = 117.6°, beyond 110
        yield ""
        assert len(journal_records(out)) == 1  # only the header: nothing was captured
        rig.servo(3).move_by_hand(900)  # 96°
        yield ""
        yield "q"

    recording, _ = rig.record(out, typing())
    assert rig.events[0] == Refused(("elbow at 117.6° is outside its limits -110..110°",))
    assert [c.angles_deg[2] for c in recording.captures] == [96.0]


def test_undo_removes_the_last_capture_and_unknown_input_is_reported(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    journal_seen = []

    def typing():
        for units in (520, 540):
            rig.servo(2).move_by_hand(units)
            yield ""
        yield "u"
        yield "x"
        rig.servo(2).move_by_hand(560)
        yield ""
        journal_seen.extend(journal_records(out))
        yield "Q"

    recording, ending = rig.record(out, typing())
    assert ending is Ending.QUIT
    assert [type(e) for e in rig.events] == [Captured, Captured, Undone, UnknownInput, Captured]
    assert rig.events[2] == Undone(2, 1)
    assert {"undo": 2} in journal_seen
    recording.save()
    assert [k.targets_deg[1] for k in load_motion(out).keyframes] == [4.8, 14.4]


def test_undo_with_nothing_captured(tmp_path):
    rig = Rig()
    recording, _ = rig.record(tmp_path / "t.yaml", ["u", "q"])
    assert rig.events == [NothingToUndo()]
    assert recording.save() is None
    assert not (tmp_path / "t.yaml").exists()


def test_end_of_input_and_ctrl_c_end_the_session_keeping_the_captures(tmp_path):
    rig = Rig()
    recording, ending = rig.record(tmp_path / "a.yaml", [""])
    assert ending is Ending.END_OF_INPUT and len(recording.captures) == 1

    lines = iter(["", ""])

    def typing_then_ctrl_c():
        line = next(lines, None)
        if line is None:
            raise KeyboardInterrupt
        return line

    recording, ending = rig.record(tmp_path / "b.yaml", typing_then_ctrl_c)
    assert ending is Ending.INTERRUPTED and len(recording.captures) == 2
    assert all(servo.loaded for servo in rig.emulator.servos)


def test_taught_joints_are_loaded_again_even_after_an_error(tmp_path):
    rig = Rig()

    def typing():
        yield ""
        raise RuntimeError("the host program failed")

    with pytest.raises(RuntimeError):
        rig.record(tmp_path / "t.yaml", typing())
    assert all(servo.loaded for servo in rig.emulator.servos)


def test_leave_unloaded_leaves_the_taught_joints_limp(tmp_path):
    rig = Rig()
    rig.record(tmp_path / "t.yaml", ["", "q"], taught=["wrist_roll"], leave_unloaded=True)
    assert [s.loaded for s in rig.emulator.servos] == [True, True, True, True, False, True]


def test_unknown_joint_names_are_refused_with_the_valid_names(tmp_path):
    rig = Rig()
    recording = Recording.start(tmp_path / "t.yaml", rig.robot)
    with pytest.raises(OptionError) as caught:
        rig.recorder(recording, taught=["elbw"])
    assert str(caught.value) == (
        "taught names an unknown joint 'elbw' (did you mean 'elbow'?); arm6's joints are "
        "base_yaw, shoulder, elbow, wrist_pitch, wrist_roll, gripper"
    )


def test_a_missing_servo_stops_before_anything_is_unloaded(tmp_path):
    rig = Rig(skip_ids=(4,))
    recording = Recording.start(tmp_path / "t.yaml", rig.robot)
    with pytest.raises(BusError, match="wrist_pitch \\(ID 4\\)"):
        with rig.recorder(recording):
            pass
    assert not [
        p for p in rig.emulator.log.packets if p.packet.command == Command.LOAD_OR_UNLOAD_WRITE
    ]
    recording.close()
    assert not journal_path(tmp_path / "t.yaml").exists()  # empty: nothing to resume


# --- the journal and resuming ------------------------------------------------------------------


def test_resume_continues_from_the_journal(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"

    def first():
        rig.servo(2).move_by_hand(600)
        yield ""
        rig.servo(3).move_by_hand(400)
        yield ""

    crashed, _ = rig.record(out, first())
    crashed.journal.close()  # the program dies here: no save

    def second():
        rig.clock.advance(3.0)
        rig.servo(2).move_by_hand(700)
        yield ""
        yield "q"

    recording, _ = rig.record(out, second(), resume=True)
    assert recording.robot.path.resolve() == rig.robot.path.resolve()  # from the journal
    recording.save()
    keyframes = load_motion(out).keyframes
    assert [k.targets_deg[1:3] for k in keyframes] == [(24, 0), (24, -24), (48, -24)]
    assert keyframes[2].after_s == pytest.approx(3.0, abs=0.05)  # since the resumed session began


def test_resume_drops_a_torn_last_line(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    crashed, _ = rig.record(out, [""])
    crashed.journal.close()
    with open(journal_path(out), "a") as journal:
        journal.write('{"capture": 2, "after_s": 0.5, "str')  # killed mid-write
    recording, _ = rig.record(out, ["", "q"], resume=True)
    assert len(recording.captures) == 2
    assert recording.save().keyframes == 2


def test_a_damaged_journal_line_is_named(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    crashed, _ = rig.record(out, ["", ""])
    crashed.journal.close()
    lines = journal_path(out).read_text().splitlines()
    lines[1] = lines[1].replace('"capture": 1', '"capture": 7')
    journal_path(out).write_text("\n".join(lines) + "\n")
    with pytest.raises(
        ChoreoError,
        match=r"taught.yaml.journal:2: damaged journal line \(capture 7 "
        r"follows capture 0\)",
    ):
        Recording.resume(out)


def test_resume_with_another_robot_is_refused(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    crashed, _ = rig.record(out, [""])
    crashed.journal.close()
    with pytest.raises(ChoreoError, match="was recorded with the robot .*arm6/robot.yaml"):
        Recording.resume(out, load_robot(TINY))


def test_starting_over_an_unfinished_journal_or_a_motion_file_is_refused(tmp_path):
    rig = Rig()
    out = tmp_path / "taught.yaml"
    crashed, _ = rig.record(out, [""])
    crashed.journal.close()
    with pytest.raises(
        ChoreoError,
        match=r"holds 1 capture\(s\) of an unfinished recording: continue it \(Recording.resume\), "
        r"or delete it to start over$",
    ):
        Recording.start(out, rig.robot)
    Recording.resume(out).save()
    with pytest.raises(
        ChoreoError,
        match=r"taught.yaml exists: choose another file, or allow replacing it \(overwrite\)$",
    ):
        Recording.start(out, rig.robot)
    Recording.start(out, rig.robot, overwrite=True).close()


def test_a_robot_found_by_no_name_is_written_as_a_relative_path(tmp_path, monkeypatch):
    monkeypatch.delenv("CHOREO_MODELS", raising=False)
    rig = Rig(TINY)
    out = tmp_path / "tiny_wave.yaml"

    def typing():
        rig.servo(2).move_by_hand(500)  # left: zero 625, direction -1: 30°
        yield ""
        yield "q"

    recording, _ = rig.record(out, typing())
    recording.save()
    robot_ref = yaml.safe_load(out.read_text())["robot"]
    assert robot_ref.startswith("../") and robot_ref.endswith("tests/data/models/tiny/robot.yaml")
    assert main(["validate", str(out)]) == 0
    assert load_motion(out).keyframes[0].targets_deg == (0, 30, 0)


# --- streams -----------------------------------------------------------------------------------


def test_a_stream_is_reduced_to_keyframes_within_the_tolerance(tmp_path):
    rig = Rig()
    out = tmp_path / "stream.yaml"
    recording = Recording.start(out, rig.robot)
    start_s = rig.clock.now()

    def hand():
        t = rig.clock.now() - start_s
        rig.servo(2).move_by_hand(500 + 250 * min(t, 2.0) / 2.0)  # shoulder 0 -> 60° in 2 s
        if t > 2.0:  # then the elbow swings out and back, a smooth curve
            rig.servo(3).move_by_hand(500 - 150 * np.sin(np.pi * min(t - 2.0, 2.0) / 2.0))
        return "" if t >= 5.0 else None

    with rig.recorder(recording) as recorder:
        assert recorder.run_stream(hand, 20) is Ending.QUIT
    samples = read_journal(journal_path(out)).captures
    sample_times = np.cumsum([0.0] + [c.after_s for c in samples[1:]])
    assert len(samples) == 101 and sample_times[-1] == pytest.approx(5.0)
    saved = recording.save(tolerance_deg=1.0)
    assert main(["validate", str(out)]) == 0
    keyframes = load_motion(out).keyframes
    assert 4 <= saved.keyframes == len(keyframes) <= 15
    key_times = np.cumsum([0.0] + [k.after_s for k in keyframes[1:]])
    assert key_times[-1] == pytest.approx(5.0)
    key_angles = np.array([k.targets_deg for k in keyframes])
    sample_angles = np.array([c.angles_deg for c in samples])
    assert key_angles[0] == pytest.approx(sample_angles[0])
    assert key_angles[-1] == pytest.approx(sample_angles[-1])
    for joint in range(len(rig.robot.joints)):
        path = np.interp(sample_times, key_times, key_angles[:, joint])
        # 1° plus what rounding the times to 10 ms can add at the hand's top speed (~40°/s)
        assert np.abs(path - sample_angles[:, joint]).max() <= 1.0 + 0.2


def test_a_stream_reports_an_excursion_once_and_drops_its_samples(tmp_path):
    rig = Rig()
    recording = Recording.start(tmp_path / "s.yaml", rig.robot)
    start_s = rig.clock.now()

    def hand():
        t = rig.clock.now() - start_s
        rig.servo(3).move_by_hand(990 if 0.2 <= t < 0.6 else 500)
        return "q" if t >= 1.0 else None

    with rig.recorder(recording) as recorder:
        recorder.run_stream(hand, 20)
    refusals = [e for e in rig.events if isinstance(e, Refused)]
    assert refusals == [Refused(("elbow at 117.6° is outside its limits -110..110°",))]
    assert len(recording.captures) == 21 - 8
    assert all(c.angles_deg[2] == 0 for c in recording.captures)


def test_a_late_sample_skips_the_slots_it_missed(tmp_path):
    rig = Rig()
    recording = Recording.start(tmp_path / "s.yaml", rig.robot)
    calls = []

    def hand():
        calls.append(rig.clock.now())
        if len(calls) == 3:
            rig.clock.advance(0.12)  # the host stalls for 120 ms
        return "" if len(calls) == 8 else None

    with rig.recorder(recording) as recorder:
        recorder.run_stream(hand, 20)
    gaps = [round(c.after_s, 6) for c in recording.captures[1:]]
    assert gaps == [0.05, 0.05, 0.15, 0.05, 0.05, 0.05, 0.05]


def test_a_slow_stream_ends_at_once_when_q_is_typed(tmp_path):
    """At 0.1 Hz the next sample is 10 s away: q typed 0.35 s in is seen within the input poll
    (0.1 s; the first sample's reads take a few ms of bus time), not at the next sample."""
    rig = Rig()
    recording = Recording.start(tmp_path / "s.yaml", rig.robot)
    start_s = rig.clock.now()
    asked = []

    def hand():
        asked.append(rig.clock.now() - start_s)
        return "q" if asked[-1] >= 0.35 else None

    with rig.recorder(recording) as recorder:
        assert recorder.run_stream(hand, 0.1) is Ending.QUIT
    assert 0.35 <= asked[-1] <= 0.35 + INPUT_POLL_S + 0.01
    assert len(recording.captures) == 1


# --- the CLI -----------------------------------------------------------------------------------


# --- a real process, killed --------------------------------------------------------------------


def test_sigkill_loses_no_capture_and_resume_picks_it_up(arm_on_a_pty, tmp_path, monkeypatch):
    emulator, link = arm_on_a_pty
    out = tmp_path / "taught.yaml"
    journal = journal_path(out)
    # A generous read timeout: on a loaded machine the bridge thread may answer late.
    command = [
        sys.executable,
        "-m",
        "choreo",
        "record",
        str(out),
        "--robot",
        "arm6",
        "--port",
        str(link),
        "--joints",
        "shoulder",
        "elbow",
        "--timeout-ms",
        "500",
    ]

    def running(process, condition):
        def check():
            if process.poll() is not None:
                raise AssertionError(f"choreo record exited early: {process.communicate()[1]}")
            return condition()

        return check

    def unloads_of_elbow():
        return sum(
            1
            for p in list(emulator.log.packets)  # list(): one step, the bridge appends
            if p.packet.command == Command.LOAD_OR_UNLOAD_WRITE
            and p.packet.servo_id == 3
            and p.packet.params == b"\x00"
        )

    def captures():
        return len(read_journal(journal).captures) if journal.exists() else 0

    def press_enter(process, count):
        process.stdin.write("\n")
        process.stdin.flush()
        wait_for(running(process, lambda: captures() == count), f"capture {count} in the journal")

    first = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        wait_for(
            running(first, lambda: unloads_of_elbow() == 1), "the recorder to unload the elbow"
        )
        emulator.servo(2).move_by_hand(600)
        press_enter(first, 1)
        emulator.servo(3).move_by_hand(400)
        press_enter(first, 2)
        first.send_signal(signal.SIGKILL)
        first.wait(WAIT_S)
    finally:
        first.kill()
    assert first.returncode == -signal.SIGKILL
    assert not out.exists()
    assert [c.angles_deg for c in read_journal(journal).captures] == [
        (0, 24, 0, 0, 0, 0),
        (0, 24, -24, 0, 0, 0),
    ]

    # resumed here (its subject is the journal the killed process left, not a process)
    read_end, write_end = os.pipe()
    keyboard = open(write_end, "w")  # closed by the typist, or below

    def type_a_capture_then_q(_said) -> None:
        try:
            wait_for(lambda: unloads_of_elbow() == 2, "the resumed recorder to unload the elbow")
            emulator.servo(2).move_by_hand(700)
            keyboard.write("\n")
            keyboard.flush()
            wait_for(lambda: captures() == 3, "capture 3 in the journal")
            keyboard.write("q\n")
        finally:
            keyboard.close()  # the input ends: a recorder still asking is not left waiting

    with keyboard, open(read_end) as typed:
        monkeypatch.setattr(sys, "stdin", typed)
        code, stdout, stderr = main_while(
            monkeypatch, type_a_capture_then_q, [*command[3:], "--resume"]
        )
    assert code == 0, stderr
    assert "resuming" in stdout and "2 capture(s) from" in stdout
    assert [k.targets_deg for k in load_motion(out).keyframes] == [
        (0, 24, 0, 0, 0, 0),
        (0, 24, -24, 0, 0, 0),
        (0, 48, -24, 0, 0, 0),
    ]
    assert not journal.exists()
    assert emulator.servo(2).loaded and emulator.servo(3).loaded


def test_resume_refuses_a_journal_whose_robot_changed_its_joints(tmp_path):
    tiny = tmp_path / "models" / "tiny"
    shutil.copytree("tests/data/models/tiny", tiny)
    rig = Rig(str(tiny / "robot.yaml"))
    out = tmp_path / "taught.yaml"
    crashed, _ = rig.record(out, [""])
    crashed.journal.close()
    text = (tiny / "robot.yaml").read_text()
    yaw = "  yaw:\n    id: 1\n    min: -90\n    max: 90\n"
    (tiny / "robot.yaml").write_text(text.replace(yaw, "").replace("poses:", yaw + "poses:"))
    with pytest.raises(
        ChoreoError,
        match="was recorded with the joints yaw, left, right, but "
        ".*robot.yaml now has left, right, yaw",
    ):
        Recording.resume(out)


def test_sighup_during_record_loads_the_taught_joints_again(arm_on_a_pty, tmp_path, monkeypatch):
    """SIGHUP sent to this process while choreo record runs here, at its prompt: its own
    handler must take it (signal_noted notes a signal no handler of the command's took)."""
    emulator, link = arm_on_a_pty
    out = tmp_path / "taught.yaml"
    argv = ["record", str(out), "--robot", "arm6", "--port", str(link), "--joints", "elbow"]
    read_end, write_end = os.pipe()
    keyboard = open(write_end, "w")  # nothing is typed; closed below

    def torque_of_elbow() -> list[bytes]:
        return [
            p.packet.params
            for p in packets(emulator, "LOAD_OR_UNLOAD_WRITE")
            if p.packet.servo_id == 3
        ]

    def hang_up_at_the_prompt(_said) -> None:
        try:
            # the keys are printed (to the command's stdout: sys.stdout here too) just before the
            # prompt reads; a SIGHUP sent as soon as the elbow was unloaded could come before
            # them, on a busy machine, and end the command as interrupted (130), not at the prompt
            wait_for(lambda: KEYS in sys.stdout.getvalue(), "the recorder's prompt")
            assert torque_of_elbow() == [b"\x00"]  # unloaded to be posed by hand
            os.kill(os.getpid(), signal.SIGHUP)
            wait_for(lambda: len(torque_of_elbow()) == 2, "the recorder to load the elbow again")
        finally:
            keyboard.close()  # the input ends: a recorder that did not stop is not left waiting

    with signal_noted(signal.SIGHUP) as unhandled, keyboard, open(read_end) as typed:
        monkeypatch.setattr(sys, "stdin", typed)
        code, stdout, stderr = main_while(
            monkeypatch, hang_up_at_the_prompt, [*argv, *PATIENT_READS[:2]]
        )
    assert unhandled == []
    assert code == 1, stderr
    # as after Ctrl-C at the prompt: the recording ends (nothing captured here, so exit 1)
    assert stdout.splitlines()[-2:] == [
        f"nothing captured: {out} not written",
        "taught joints loaded again, holding where they are",
    ]
    assert torque_of_elbow() == [b"\x00", b"\x01"]  # loaded again, holding where it is


def test_joints_that_cannot_load_again_for_one_reason_are_named_in_one_sentence(
    tmp_path, monkeypatch
):
    rig = Rig()
    recording = Recording.start(tmp_path / "taught.yaml", rig.robot)

    def refuse(bus, servo_id, on):
        if on:  # the board's one refusal, as the LOBOT controller gives it for every servo
            raise BusError("the board cannot load (torque on) a servo")

    monkeypatch.setattr("choreo.play.recorder.servo_config.set_torque", refuse)
    with pytest.raises(BusError) as caught:
        with rig.recorder(recording, taught=["wrist_roll", "gripper"]):
            pass
    assert str(caught.value) == (
        "could not load again, so these joints may be limp: wrist_roll, gripper: the board "
        "cannot load (torque on) a servo"
    )
